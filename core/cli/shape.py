"""``python -m core.shape --case CASE [--runs N] [--seed S] [--lag N] --out DIR``.

Runs a case of seed 003 (:data:`core.shape.cases.CASES`) with ``runs`` Monte-Carlo passes
(1 to :data:`MAX_RUNS`: each run keeps ~0.3 MB of tracks and covariances in memory) and writes
into DIR:

- ``summary.json``: the case's truth and, per row of the case (Tables have several), per filter
  ("euler", "ukf", "nhukf") ``centroid_error_m``, ``peak_error_m``, ``main_scale_m``,
  ``main_scale_error_m``, ``axis_error_deg``, ``kind``, ``nees`` (medians over runs; the
  metrics of :mod:`core.shape.experiment`: ``kind`` is the majority verdict or ``"tie"``,
  ``main_scale_m`` the median over the runs of the majority kind, null on a tie); the
  top-level ``filters`` and ``truth`` are the first row's;
- ``errors_rowI.png``: position error along the pass for each filter (run 0), outliers marked;
- ``shape_rowI.png``: run 0's final dipoles and PCA axes over the target's outline, plan (x–y)
  and side (x–z) views.

The filter update is the case's own (:mod:`core.shape.cases`): seed 003's window of lag 5, and
for Figs. 4 and 5 a second row with the one-sample update beside it (``"comparison": true``);
``--lag N`` sets one update for every row (0: one sample) and drops the comparison rows, with
2N below the pass's sample count (81 samples: N ≤ 40). The summary's ``description`` names the
update each row ran.

Every bad input prints one line ``python -m core.shape: error: …`` and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import replace

import numpy as np

from ..shape.cases import CASES, case_rows, describe
from ..shape.experiment import run_case
from . import ArgumentParser

PROG = "python -m core.shape"
#: Largest ``--runs``: each run keeps ~0.3 MB (the two filters' 81 covariances of 15 × 15, the
#: tracks), so 10000 runs need ~3 GB.
MAX_RUNS = 10000


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
    p = _Parser(prog=PROG, description=__doc__.split("\n")[0])
    p.add_argument("--case", required=True, choices=list(CASES), metavar="CASE",
                   help="one of " + ", ".join(CASES))
    p.add_argument("--runs", type=_int(1, "Monte-Carlo passes", MAX_RUNS,
                                       ": each keeps ~0.3 MB in memory"), default=1,
                   help=f"Monte-Carlo passes, 1 to {MAX_RUNS} (default 1)")
    p.add_argument("--seed", type=_int(0, "random seed"), default=0)
    p.add_argument("--lag", type=_int(0, "seed 003's window lag n; 0 = one-sample update"), default=None,
                   help="the update's window lag n for every row: 0 = one-sample update, n > 0 = "
                        "seed 003's [k − 2n, k − n, k] with 2n below the sample count (81: n ≤ 40); "
                        "default: the case's own (figures 0, tables 5)")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    return p


def _check_out(out):
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"--out must be a folder; {out!r} is a file")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out {out!r} cannot be created: {exc.strerror}") from None
    if not os.access(out, os.W_OK):
        raise ValueError(f"--out {out!r} is not writable")


def check_lag(case, lag):
    """ValueError unless every row of ``case`` can take the window lag ``lag`` (None: the rows'
    own): seed 003's window [k − 2n, k − n, k] needs 2n below the pass's sample count."""
    for row in case_rows(case)[1]:
        n = row.lag if lag is None else lag
        K = row.track.samples
        if 2 * n >= K:
            raise ValueError(f"--lag {n} is too large for {case}: its pass has {K} samples and the "
                             f"window [k − 2n, k − n, k] needs 2n < {K}; the largest lag accepted "
                             f"is {(K - 1) // 2}")


def _json_safe(v):
    """NaN → None (strict JSON: null), recursively."""
    if isinstance(v, float) and math.isnan(v):
        return None
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    return v


def _plot_errors(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for name, style in (("euler", ":"), ("ukf", "-"), ("nhukf", "--")):
        if name in res.errors:
            ax.semilogy(res.platform_x, res.errors[name][0], style, label=name.upper())
    for k in res.outlier_samples:
        ax.axvline(res.platform_x[k], color="r", alpha=0.4, lw=1)
    if res.outlier_samples:
        ax.plot([], [], color="r", alpha=0.4, label="outlier")
    ax.set_xlabel("platform x (m)")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{res.case.name}: error along the pass (run 0)")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _plot_shape(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 4.2))
    t = res.case.target
    for ax, (i, j, lab) in zip(axes, ((0, 1, "plan: x–y"), (0, 2, "side: x–z"))):
        for ln in t.outline():
            ax.plot(ln[:, i], ln[:, j], color="0.6", lw=1)
        for name, mk in (("ukf", "o"), ("nhukf", "^")):
            if name not in res.dipoles:
                continue
            d = res.dipoles[name][0]
            ax.plot(d[:, i], d[:, j], mk, label=f"{name.upper()} dipoles")
            c, V, w = res.final[name]["centroid"][0], res.final[name]["axes"][0], res.final[name]["eigenvalues"][0]
            for q in range(2):
                half = np.sqrt(max(w[q], 0.0)) * 2 * V[:, q]
                ax.plot([c[i] - half[i], c[i] + half[i]], [c[j] - half[j], c[j] + half[j]],
                        "-" if q == 0 else "--", lw=1.5)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("xyz"[i] + " (m)")
        ax.set_ylabel("xyz"[j] + " (m)" + (" (down)" if j == 2 else ""))
        ax.set_title(lab)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{res.case.name}: dipoles and PCA axes (±2√λ) over the outline")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run(case, runs=1, seed=0, lag=None, out=None, plots=True):
    """Run a case; write summary.json (and plots) into ``out`` if given. Returns the summary
    (as written: NaN as None). ``lag`` None keeps each row's own update (cases.py)."""
    desc, rows = case_rows(case)
    check_lag(case, lag)
    if lag is not None:  # one update for every row: the comparison rows would repeat the main ones
        rows = [replace(row, lag=lag) for row in rows if not row.comparison]
    results = [run_case(row, runs=runs, seed=seed) for row in rows]
    summary = {"case": case, "description": describe(desc, rows), "runs": runs, "seed": seed,
               "lag": results[0].case.lag,
               "truth": results[0].summary["case"], "filters": results[0].summary["filters"],
               "rows": [{"label": r.case.name, "comparison": r.case.comparison,
                          "truth": r.summary["case"], "filters": r.summary["filters"],
                         "outlier_samples": r.outlier_samples} for r in results]}
    summary = _json_safe(summary)
    if out is not None:
        with open(os.path.join(out, "summary.json"), "w", encoding="utf-8") as fh:
            json.dump(summary, fh, indent=1, allow_nan=False)
        if plots:
            for i, r in enumerate(results):
                _plot_errors(r, os.path.join(out, f"errors_row{i}.png"))
                _plot_shape(r, os.path.join(out, f"shape_row{i}.png"))
    return summary


def _fmt(v, spec):
    return "—" if v is None else format(v, spec)


def main(argv=None):
    a = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    try:
        check_lag(a.case, a.lag)
        _check_out(a.out)
    except ValueError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        sys.exit(2)
    s = run(a.case, runs=a.runs, seed=a.seed, lag=a.lag, out=a.out)
    for row in s["rows"]:
        f = row["filters"]
        print(f"{row['label']}: " + "; ".join(
            f"{n} centroid {_fmt(v['centroid_error_m'], '.3f')} m" + (
                f", scale {_fmt(v['main_scale_m'], '.2f')} m, axis {v['axis_error_deg']:.1f}°, {v['kind']}"
                if "kind" in v else "") for n, v in f.items()))
    print(f"wrote {os.path.join(a.out, 'summary.json')}")
    return s
