"""``python -m core.shape --case CASE [--runs N] [--seed S] [--lag N] [--offset Y] [--above Z]
[--noise σ] [--speed V] [--rate F] [--cpa-sweep LO:HI:N [--size-to X]] --out DIR``: seed 003's
Monte-Carlo passes of a case (:data:`core.shape.cases.CASES`), written to DIR as ``summary.json``
(:func:`run`), ``errors_rowI.png`` and ``shape_rowI.png`` per row and, with ``--cpa-sweep``,
``cpa_sweep.csv`` and ``.png`` (:func:`cpa_sweep`). Options, limits (:data:`LIMITS`), outputs,
warnings: docs/shape.md, *Command line*. Every bad input prints one line
``python -m core.shape: error: …`` and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import replace

import numpy as np

from ..shape.bound import SIZABLE_FRACTION, SIZABLE_RULE, SIZABLE_Z, shape_bound
from ..shape.cases import CASES, PAPER_LAG, case_rows, describe
from ..shape.experiment import run_case
from ..shape.model import N_DIPOLES
from ..shape.sizing import sized as sized_passes
from ..shape.targets import CLEARANCE, Pass, clearance
from . import ArgumentParser
from .shape_plots import plot_errors, plot_shape, plot_sweep

PROG = "python -m core.shape"
#: Largest ``--runs``: each run keeps ~0.3 MB (the two filters' 81 covariances of 15 × 15, the
#: tracks), so 10000 runs need ~3 GB.
MAX_RUNS = 10000
#: Limits of the pass options: name -> (lowest, highest, unit). Offset and height as the Shape
#: tab's; speed and rate keep the 80 m pass between 2 and MAX_SAMPLES samples.
LIMITS = {"offset": (-100.0, 100.0, "m"), "above": (-100.0, 100.0, "m"),
          "noise": (1e-5, 10.0, "nT/m"), "speed": (0.5, 20.0, "m/s"), "rate": (0.1, 50.0, "Hz")}
#: Most samples a pass may have (80 · rate / speed + 1): the filters' cost is linear in them.
MAX_SAMPLES = 2001
#: Fewest samples a pass may have: the 4-dipole model's 15 unknowns over 5 readings a sample
#: (with fewer the Fisher matrix is singular, and the bound and the fit's σ mean nothing).
MIN_SAMPLES = -(-(3 * N_DIPOLES + 3) // 5)
#: Length of the pass along x (m): x = −40 … +40, as seed 003's.
PASS_LENGTH = 80.0
#: Most closest approaches of a --cpa-sweep.
MAX_SWEEP = 40


class _Parser(ArgumentParser):
    def error(self, message):  # one line, status 2 (argparse's default adds the usage text)
        print(f"{PROG}: error: {message}", file=sys.stderr)
        sys.exit(2)


def _int(lo, what, hi=None, why=""):
    def conv(s):
        try:
            v = int(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer ≥ {lo} ({what}); got {s!r}") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"must be an integer ≥ {lo} ({what}); got {s!r}")
        if hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"must be at most {hi} ({what}{why}); got {s!r}")
        return v
    return conv


def _parser():
    # plain text: the module's notes are reStructuredText, and their first line a usage line
    p = _Parser(prog=PROG, description="Run one of seed 003's target-sizing cases (Monte-Carlo "
                                       "passes over the target) and write summary.json and its "
                                       "figures into OUT.")
    p.add_argument("--case", required=True, choices=list(CASES), metavar="CASE",
                   help="one of " + ", ".join(CASES))
    p.add_argument("--runs", type=_int(1, "Monte-Carlo passes", MAX_RUNS,
                                       ": each keeps ~0.3 MB in memory"), default=1,
                   help=f"Monte-Carlo passes, 1 to {MAX_RUNS} (default 1)")
    p.add_argument("--seed", type=_int(0, "random seed"), default=0)
    p.add_argument("--lag", type=_int(0, "seed 003's window lag n; 0 = one-sample update"), default=None,
                   help="the update's window lag n for every row: 0 = one-sample update, n > 0 = "
                        "seed 003's [k − 2n, k − n, k] with 2n below the sample count (81: n ≤ 40); "
                        f"default: the case's own, seed 003's window of lag {PAPER_LAG} for every "
                        "case, with the one-sample update beside it for Figs. 4 and 5 (dropped "
                        "when --lag is given)")
    for name, what in (("offset", "lateral offset y of the track from the target's centre"),
                       ("above", "height of the track above the target's centre (z is down)"),
                       ("noise", "noise σ of each tensor component"),
                       ("speed", "platform speed along +x"), ("rate", "sampling rate")):
        lo, hi, unit = LIMITS[name]
        p.add_argument(f"--{name}", type=_float(lo, hi, unit, what), default=None,
                       help=f"{what}, {lo:g} to {hi:g} {unit} (default: the case's)")
    p.add_argument("--cpa-sweep", type=_sweep, default=None, metavar="LO:HI:N",
                   help="also sweep the closest approach from LO to HI m in N steps (CSV + PNG)")
    p.add_argument("--size-to", type=_float(1e-6, 1e6, "m", "the σ to size the main scale to"),
                   default=None, help="with --cpa-sweep: the main scale's σ to reach (m; default "
                                      f"{100 * SIZABLE_FRACTION:g} %% of it)")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    return p


def _float(lo, hi, unit, what):
    def conv(s):
        try:
            v = float(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a number ({what}, {unit}); got {s!r}") from None
        if not math.isfinite(v) or not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"must be between {lo:g} and {hi:g} {unit} ({what}); got {s!r}")
        return v
    return conv


def _sweep(s):
    parts = s.split(":")
    try:
        lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
        if len(parts) != 3:
            raise ValueError
    except (ValueError, IndexError):
        raise argparse.ArgumentTypeError(f"must be LO:HI:N (closest approaches in m, N steps), e.g. "
                                         f"5:40:8; got {s!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi <= 1000):
        raise argparse.ArgumentTypeError(f"needs 0 < LO < HI ≤ 1000 m; got {s!r}")
    if not 2 <= n <= MAX_SWEEP:
        raise argparse.ArgumentTypeError(f"N must be 2 to {MAX_SWEEP} steps; got {s!r}")
    return lo, hi, n


def geometry(row, offset=None, above=None, noise=None, speed=None, rate=None):
    """``row`` (a Case) with the pass options applied (None: the row's own); ValueError for a pass
    the options make impossible (too many samples, through the target)."""
    t = row.track
    st, v = np.asarray(t.start, float), np.asarray(t.velocity, float)
    y = st[1] if offset is None else offset
    z = st[2] if above is None else -above
    spd = float(np.linalg.norm(v)) if speed is None else speed
    hz = float(t.rate) if rate is None else rate
    if speed is None and rate is None:
        samples = t.samples
    else:
        samples = int(round(PASS_LENGTH * hz / spd)) + 1
        if samples < MIN_SAMPLES:
            raise ValueError(f"--rate {hz:g} Hz at --speed {spd:g} m/s makes {samples} sample"
                             f"{'s' if samples > 1 else ''} over the {PASS_LENGTH:g} m pass; the "
                             f"4-dipole model has {3 * N_DIPOLES + 3} unknowns and a sample gives 5 "
                             f"readings, so at least {MIN_SAMPLES} (rate / speed ≥ "
                             f"{(MIN_SAMPLES - 1) / PASS_LENGTH:g} per m)")
        if samples > MAX_SAMPLES:
            raise ValueError(f"--rate {hz:g} Hz at --speed {spd:g} m/s makes {samples} samples over "
                             f"the {PASS_LENGTH:g} m pass; at most {MAX_SAMPLES} (rate / speed ≤ "
                             f"{(MAX_SAMPLES - 1) / PASS_LENGTH:g} per m)")
    track = Pass(start=(-PASS_LENGTH / 2, y, z), velocity=(spd, 0.0, 0.0), rate=hz, samples=samples)
    near = clearance(row.target, track)
    if near < CLEARANCE:
        raise ValueError(f"the track passes {near:.2f} m from the target's nearest cell; keep it at "
                         f"least {CLEARANCE:g} m away (--offset, --above)")
    out = replace(row, track=track)
    if noise is not None:
        out = replace(out, noise_g=noise, noise_b=noise)
    return out


def rows_of(case, lag=None, **geo):
    """The rows ``run`` runs: the case's, with ``lag`` and the pass options (:func:`geometry`)."""
    rows = case_rows(case)[1]
    if lag is not None:  # one update for every row: the comparison rows would repeat the main ones
        rows = [replace(row, lag=lag) for row in rows if not row.comparison]
    return [geometry(row, **geo) for row in rows]


def _check_out(out):
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"--out must be a folder; {out!r} is a file")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out {out!r} cannot be created: {exc.strerror}") from None
    if not os.access(out, os.W_OK):
        raise ValueError(f"--out {out!r} is not writable")


def check_lag(case, lag, **geo):
    """ValueError unless every row of ``case`` (with the pass options ``geo``) can take the window
    lag ``lag`` (None: the rows' own): seed 003's window [k − 2n, k − n, k] needs 2n below the
    pass's sample count."""
    for row in rows_of(case, None, **geo):
        n = row.lag if lag is None else lag
        K = row.track.samples
        if 2 * n >= K:
            raise ValueError(f"--lag {n} is too large for {case}: its pass has {K} samples and the "
                             f"window [k − 2n, k − n, k] needs 2n < {K}; the largest lag accepted "
                             f"is {(K - 1) // 2}")


def _json_safe(v):
    """NaN and ±inf → None (strict JSON: null), recursively."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    return v


def _row_summary(r, bound):
    return {"label": r.case.name, "comparison": r.case.comparison, "truth": r.summary["case"],
            "filters": r.summary["filters"], "outlier_samples": r.outlier_samples,
            "settle_samples": r.summary["settle_samples"],
            "bound": bound.to_dict(), "sizable": bound.sizable, "verdict": bound.verdict,
            "sizing": bound.sizing}


def run(case, runs=1, seed=0, lag=None, out=None, plots=True, **geo):
    """Run a case; write summary.json (and plots) into ``out`` if given. Returns the summary
    (as written: NaN as None). ``lag`` None keeps each row's own update (cases.py); ``geo``: the
    pass options of :func:`geometry` (offset, above, noise, speed, rate)."""
    desc, _ = case_rows(case)
    check_lag(case, lag, **geo)
    rows = rows_of(case, lag, **geo)
    results = [run_case(row, runs=runs, seed=seed) for row in rows]
    bounds = [shape_bound(r.target, r.track, r.noise_g) for r in rows]
    per_row = [_row_summary(r, b) for r, b in zip(results, bounds)]
    summary = {"case": case, "description": describe(desc, rows), "runs": runs, "seed": seed,
               "lag": results[0].case.lag, "truth": results[0].summary["case"],
               "filters": results[0].summary["filters"], "bound": per_row[0]["bound"],
               "sizable": per_row[0]["sizable"], "sizing": per_row[0]["sizing"], "rows": per_row}
    summary = _json_safe(summary)
    if out is not None:
        with open(os.path.join(out, "summary.json"), "w", encoding="utf-8") as fh:
            json.dump(summary, fh, indent=1, allow_nan=False)
        if plots:
            for i, r in enumerate(results):
                plot_errors(r, os.path.join(out, f"errors_row{i}.png"))
                plot_shape(r, os.path.join(out, f"shape_row{i}.png"))
    return summary


def cautions(row):
    """CAUTION lines of a summary row: an estimator whose verdict is not the truth's kind."""
    truth = row["truth"]["target"]["kind"]
    out = []
    for name, v in row["filters"].items():
        if "kind" in v and v["kind"] not in (truth, "none"):  # none: no converged fit (fit_lines)
            share = v["kind_share"].get(v["kind"], 0.0) if v["kind"] != "tie" else 0.5
            out.append(f"CAUTION: {name} reads {'a tie' if v['kind'] == 'tie' else 'a ' + v['kind']}"
                       f" ({100 * share:.0f} % of runs) but the target is a {truth}: its main scale "
                       f"and axis are not the target's")
    return out


def warning(row):
    """The WARNING line of a summary row the pass cannot size (else '')."""
    if row["sizable"]:
        return ""
    b = row["bound"]
    truth = row["truth"]["target"]["main_scale_m"]
    if b["verdict"] == "borderline":
        return (f"WARNING: this pass is at the edge of sizing the target: for the best read "
                f"({b['sizing']}) |model bias| {abs(b['best_bias_m']):.2g} m + {SIZABLE_Z:g} × σ "
                f"{b['best_main_scale_m']:.3g} m = {b['margin_m']:.3g} m, above "
                f"{100 * SIZABLE_FRACTION:g} % of the main scale ({truth:g} m), though σ itself is "
                "below it; there the batch fit sizes some passes but not most (it falls into "
                "wrong-axis minima): pass closer, or see --cpa-sweep")
    head = (f"WARNING: this pass cannot size the target: for the best read ({b['sizing']}) "
            f"|model bias| {abs(b['best_bias_m']):.2g} m + {SIZABLE_Z:g} × σ "
            f"{b['best_main_scale_m']:.3g} m = {b['margin_m']:.3g} m, above "
            f"{100 * SIZABLE_FRACTION:g} % of the main scale ({truth:g} m); ")
    if abs(b["best_bias_m"]) > SIZABLE_FRACTION * truth:
        return head + (f"the 4-dipole model's bias alone is more: the main scales of {row['label']} "
                       "are off by it at any distance and noise (their axes and line / plane "
                       "verdicts may still hold)")
    return head + (f"the main scales, axes and line / plane verdicts of {row['label']} are noise, "
                   "not a size (pass closer, or see --cpa-sweep)")


#: Columns of cpa_sweep.csv: the bound's σ of the main scale (span read, second-moment read,
#: rigid line), the verdict, and per estimator the Monte-Carlo medians of |main scale − truth|
#: in both reads and of the axis error (the fit's over its converged passes: NaN if none), the
#: fit's share of converged passes and of passes it sized (:func:`core.shape.sizing.sized`).
ESTIMATORS = ("ukf", "nhukf", "fit")
SWEEP_COLUMNS = (["closest_approach_m", "bound_span_m", "bound_second_moment_m", "bound_rigid_line_m",
                  "sizable", "verdict"]
                 + [f"{e}_{q}" for e in ESTIMATORS
                    for q in ("span_error_m", "second_moment_error_m", "axis_error_deg")]
                 + ["fit_converged_share", "fit_sized_share"])
#: An estimator sizes the target at a closest approach when the median error of its best read is
#: within 10 % of the main scale and its median axis error within this (°): a length along the
#: wrong axis is no size.
SIZED_AXIS_DEG = 10.0


def _crossing(cpas, values, level):
    """Largest closest approach (log-log interpolation) where ``values`` (increasing with the
    closest approach) is ≤ ``level``; None if not even at the first, inf if at the last."""
    v = np.asarray(values, float)
    ok = v <= level
    if not ok[0]:
        return None
    if ok.all():
        return math.inf
    i = int(np.argmin(ok)) - 1  # last ≤ before the first >
    x0, x1, y0, y1 = np.log(cpas[i]), np.log(cpas[i + 1]), np.log(v[i]), np.log(v[i + 1])
    return float(np.exp(x0 + (np.log(level) - y0) * (x1 - x0) / (y1 - y0)))


def cpa_sweep(case, lo, hi, n, runs=1, seed=0, lag=None, out=None, size_to=None, plots=True, **geo):
    """The bound and the Monte-Carlo errors of the first row against the closest approach (module
    notes); writes cpa_sweep.csv (and .png) into ``out`` if given. Returns a dict: ``records``
    (one per closest approach, :data:`SWEEP_COLUMNS`), ``size_to_m``, ``bound_cpa_m`` (the
    farthest pass whose best bound is ≤ size_to) and ``monte_carlo_cpa_m`` (the farthest swept
    pass where an estimator sizes the target to it)."""
    row = rows_of(case, lag, **geo)[0]
    cpas = np.geomspace(lo, hi, n)
    cases = []
    for c in cpas:
        r = replace(row, track=row.track.with_closest_approach(float(c)))
        near = clearance(r.target, r.track)
        if near < CLEARANCE:
            raise ValueError(f"--cpa-sweep: at a closest approach of {c:.3g} m the track passes "
                             f"{near:.2f} m from the target's nearest cell; start the sweep farther "
                             f"(at least {CLEARANCE:g} m from the target)")
        cases.append(r)
    truth = row.target.main_scale
    size_to = SIZABLE_FRACTION * truth if size_to is None else float(size_to)
    records, sized = [], []
    for r in cases:
        b = shape_bound(r.target, r.track, r.noise_g)
        res = run_case(r, runs=runs, seed=seed)
        rec = {"closest_approach_m": b.closest_approach_m, "bound_span_m": b.main_scale_m,
               "bound_second_moment_m": b.spread_main_scale_m, "bound_rigid_line_m": b.rigid_main_scale_m,
               "sizable": b.sizable, "verdict": b.verdict}
        ok = False
        for e in ESTIMATORS:
            f = res.final[e]
            if e == "fit":  # a fit that did not converge (or ran off) is no answer
                keep = np.asarray(f["converged"], bool)
                f = {k: np.asarray(f[k])[keep] for k in ("main_scale_m", "spread_scale_m", "axis_error_deg")}
                rec["fit_converged_share"] = float(np.mean(keep))
                rec["fit_sized_share"] = float(np.mean(sized_passes(res, b)))
                if not keep.any():
                    rec.update({f"fit_{q}": float("nan") for q in
                                ("span_error_m", "second_moment_error_m", "axis_error_deg")})
                    continue
            second = f["spread_scale_m"] if r.target.kind == "line" else f["main_scale_m"]
            rec[f"{e}_span_error_m"] = float(np.median(np.abs(f["main_scale_m"] - truth)))
            rec[f"{e}_second_moment_error_m"] = float(np.median(np.abs(second - truth)))
            rec[f"{e}_axis_error_deg"] = float(np.median(f["axis_error_deg"]))
            best = min(rec[f"{e}_span_error_m"], rec[f"{e}_second_moment_error_m"])
            ok |= best <= size_to and rec[f"{e}_axis_error_deg"] <= SIZED_AXIS_DEG
        sized.append(ok)
        records.append(rec)
    best_bound = [min(r["bound_span_m"], r["bound_second_moment_m"]) for r in records]
    mc = [c for c, ok in zip(cpas, sized) if ok]
    result = {"records": records, "size_to_m": size_to, "main_scale_m": truth, "runs": runs,
              "bound_cpa_m": _crossing(cpas, best_bound, size_to),
              "monte_carlo_cpa_m": float(max(mc)) if mc else None,
              "monte_carlo_sized": sized}
    if out is not None:
        import csv
        with open(os.path.join(out, "cpa_sweep.csv"), "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=SWEEP_COLUMNS)
            w.writeheader()
            for rec in records:
                w.writerow({k: (str(v).lower() if isinstance(v, bool) else v if isinstance(v, str)
                                else f"{v:.6g}") for k, v in rec.items()})
        if plots:
            plot_sweep(result, row, os.path.join(out, "cpa_sweep.png"))
    return result


def sweep_answer(sw):
    """The sweep's answer in words: how close the pass must be."""
    x, b, m = sw["size_to_m"], sw["bound_cpa_m"], sw["monte_carlo_cpa_m"]
    lo = sw["records"][0]["closest_approach_m"]
    hi = sw["records"][-1]["closest_approach_m"]
    if b is None:
        bound = f"no swept pass (from {lo:.3g} m) is close enough by the bound"
    elif math.isinf(b):
        bound = f"every swept pass (to {hi:.3g} m) is close enough by the bound"
    else:
        bound = f"the pass must come within {b:.3g} m by the bound (the best read's σ ≤ {x:.3g} m)"
    mc = ("no swept pass sized it in the Monte-Carlo" if m is None else
          f"in the Monte-Carlo ({sw['runs']} passes each) an estimator sized it to {x:.3g} m (axis "
          f"within {SIZED_AXIS_DEG:g}°) up to {m:.3g} m")
    return f"To size this target ({sw['main_scale_m']:g} m) to {x:.3g} m: {bound}; {mc}."


def _fmt(v, spec):
    return "—" if v is None else format(v, spec)


def _estimator_text(name, v):
    """One estimator's medians in words (the fit: over its converged passes)."""
    if name == "fit" and not v["converged_runs"]:
        return "fit: no pass converged to a plausible answer (below)"
    text = f"{name} centroid {_fmt(v['centroid_error_m'], '.3f')} m"
    if "kind" in v:
        text += (f", scale {_fmt(v['main_scale_m'], '.2f')} m (second moment "
                 f"{_fmt(v['spread_scale_m'], '.2f')} m), axis {_fmt(v['axis_error_deg'], '.1f')}°, "
                 f"{v['kind']}")
    return text


def fit_lines(v):
    """The batch fit's lines under a row: its σ of the main scale beside the model's bias, and
    how many passes did not converge to a plausible answer (summary's fit entry ``v``)."""
    out = []
    if v["converged_runs"]:
        parts = []
        for read, sig, bias in (("span", v["main_scale_sigma_m"], v["main_scale_bias_m"]),
                                ("second moment", v["spread_scale_sigma_m"], v["spread_scale_bias_m"])):
            ratio = f", {abs(bias) / sig:.2g}× the σ" if sig and bias is not None else ""
            parts.append(f"{read} σ {_fmt(sig, '.2g')} m, bias {_fmt(bias, '+.2g')} m{ratio}")
        out.append("fit main scale, σ (noise; median over passes) beside the model bias (4 dipoles "
                   "for the target's cells: the fit of the noise-free readings; not in the σ): "
                   + "; ".join(parts))
    if v["converged_share"] < 1:
        runs = v["runs"]
        bad = runs - v["converged_runs"]
        out.append(f"WARNING: the fit did not converge to a plausible answer in {bad} of {runs} "
                   f"pass{'es' if runs > 1 else ''} ({1 - v['plausible_share']:.0%} ended with a dipole farther from the "
                   "centroid than the track is, i.e. not one target beside the track); "
                   "they are left out of its medians")
    return out


def main(argv=None):
    a = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    geo = dict(offset=a.offset, above=a.above, noise=a.noise, speed=a.speed, rate=a.rate)
    try:
        check_lag(a.case, a.lag, **geo)
        if a.size_to is not None and a.cpa_sweep is None:
            raise ValueError("--size-to needs --cpa-sweep")
        _check_out(a.out)
        sw = None if a.cpa_sweep is None else cpa_sweep(
            a.case, *a.cpa_sweep, runs=a.runs, seed=a.seed, lag=a.lag, out=a.out,
            size_to=a.size_to, **geo)
    except ValueError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        sys.exit(2)
    s = run(a.case, runs=a.runs, seed=a.seed, lag=a.lag, out=a.out, **geo)
    for row in s["rows"]:
        f = row["filters"]
        b = row["bound"]
        print(f"{row['label']}: " + "; ".join(_estimator_text(n, v) for n, v in f.items()))
        if "fit" in f:
            for line in fit_lines(f["fit"]):
                print("  " + line)
        print(f"  bound of the main scale (1σ): span {b['main_scale_m']:.3g} m, second moment "
              f"{b['spread_main_scale_m']:.3g} m, rigid line {_fmt(b['rigid_main_scale_m'], '.3g')} m; "
              + {"sizable": "sizable", "borderline": "BORDERLINE"}.get(b["verdict"], "NOT sizable")
              + f" ({b['sizing']} read; rule: "
              f"{SIZABLE_RULE})")
        if "fit" in f and f["fit"]["converged_runs"]:
            band = f["fit"]["nees_band"]
            if not band[0] <= f["fit"]["nees"] <= band[1]:
                print(f"  WARNING: the fit's centroid NEES {f['fit']['nees']:.3g} is outside its 99 % "
                      f"band {band[0]:.3g} … {band[1]:.3g}: its σ is "
                      + ("optimistic" if f["fit"]["nees"] > band[1] else "pessimistic"))
        for line in cautions(row):
            print("  " + line)
        w = warning(row)
        if w:
            print("  " + w)
    if sw is not None:
        s["cpa_sweep"] = _json_safe({k: v for k, v in sw.items() if k != "records"}
                                    | {"csv": "cpa_sweep.csv", "png": "cpa_sweep.png"})
        with open(os.path.join(a.out, "summary.json"), "w", encoding="utf-8") as fh:
            json.dump(s, fh, indent=1, allow_nan=False)
        print(sweep_answer(sw))
        print(f"wrote {os.path.join(a.out, 'cpa_sweep.csv')} and cpa_sweep.png")
    print(f"wrote {os.path.join(a.out, 'summary.json')}")
    return s
