"""``python -m core.calibration DATA.csv --be BX,BY,BZ``: calibrate a magnetometer from a CSV log.

Prints K and Bp (Kalman filter and least squares), the rank of Γ, the CRLB, the error of the
geomagnetic solution and, in words, whatever makes them untrustworthy (:func:`fit_diagnosis`).
Every bad input or option (a file the parser refuses, a value out of range, an unknown option)
gives one line on stderr and exit code 2; never a traceback. The only module of the package
that imports argparse; ``core`` does not import it.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from ..calibration.data import MAX_CSV_BYTES, MAX_CSV_ROWS, read_attitude_csv
from ..calibration.estimators import (
    DEFAULT_P0_DIAG,
    MAX_KALMAN_ITERATIONS,
    default_iterations,
    kalman_calibrate,
    lsq_calibrate,
)
from ..calibration.geomagnetic import geomagnetic_error, geomagnetic_solution
from ..calibration.misfit import fit_diagnosis
from ..calibration.model import COEFFICIENTS, CONVENTIONS
from ..calibration.observability import calibration_crlb, calibration_observability
from ..calibration.validation import (
    NOISE_RANGE_NT,
    checked_angle_noise,
    checked_be,
    checked_noise,
)
from ..model.validation import integer
from . import ArgumentParser

PROG = "python -m core.calibration"


class _Parser(ArgumentParser):
    """argparse's parser with its errors as ValueError, so that every bad option reaches the
    same one-line message as a bad file (argparse prints usage and a second line otherwise)."""

    def error(self, message):
        raise ValueError(message)


def _parse_be(text):
    parts = text.replace("−", "-").split(",")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != 3 or not all(np.isfinite(vals)):
        raise ValueError(f"--be must be three comma-separated numbers in nT (north, east, down), "
                         f"e.g. --be 34425,1961,35898; got {text!r}")
    try:
        return checked_be(vals)
    except ValueError as exc:
        raise ValueError(f"--be: {exc}") from None


def _finite_or_none(v):
    return None if not np.isfinite(v) else float(v)


def _cli_result(B, att, be, *, sigma_nt, angle_sigma_deg, iterations, convention):
    """Everything the CLI reports, as one JSON-able dict."""
    sa = np.deg2rad(angle_sigma_deg)
    lsq = lsq_calibrate(B, att, be, convention=convention)
    kal = kalman_calibrate(B, att, be, sigma_nt=sigma_nt, iterations=iterations,
                           convention=convention)
    obs = calibration_observability(att, be, convention=convention)
    crlb = calibration_crlb(att, be, noise_nt=sigma_nt, angle_noise_rad=sa, K=lsq.K,
                            convention=convention)
    diag = fit_diagnosis(B, att, be, noise_nt=sigma_nt, angle_noise_rad=sa, convention=convention)
    errors = {}
    for key, (K, Bp) in (("kalman", (kal.K, kal.Bp)), ("lsq", (lsq.K, lsq.Bp))):
        try:
            errors[key] = geomagnetic_error(geomagnetic_solution(B, att, K, Bp, convention=convention), be)
        except ValueError:  # K not invertible: no geomagnetic solution to report
            errors[key] = None
    err, err_l = errors["kalman"], errors["lsq"]
    from_res = None
    if diag.noise_misstated:  # the bound for the noise the residuals give, beside the stated one's
        s = diag.reading_sigma_hat_nt
        from_res = {"sigma_nT": s, "ratio": diag.ratio, "crlb": {
            c: _finite_or_none(v) for c, v in zip(COEFFICIENTS, calibration_crlb(
                att, be, noise_nt=s, angle_noise_rad=sa, K=lsq.K, convention=convention))}}
    return {
        "convention": convention, "n_attitudes": int(att.shape[0]), "be_nT": be.tolist(),
        "K": kal.K.tolist(), "Bp": kal.Bp.tolist(), "K_lsq": lsq.K.tolist(), "Bp_lsq": lsq.Bp.tolist(),
        "lsq_unique": obs.rank == 12, "residual_rms_nT_lsq": float(lsq.residual_rms_nt),
        "rank": obs.rank, "unobservable": list(obs.descriptions),
        "crlb": {c: _finite_or_none(s) for c, s in zip(COEFFICIENTS, crlb)},
        "crlb_noise": {"sigma_nT": sigma_nt, "angle_sigma_deg": angle_sigma_deg},
        "crlb_from_residuals": from_res,
        "kalman": {"iterations": iterations, "sigma_nT": sigma_nt, "x0": "zero",
                   "P0_diag": list(DEFAULT_P0_DIAG), "Q": 0.0},
        "be_rms_nT": None if err is None else err.rms_nt,
        "be_vector_rms_nT": None if err is None else err.vector_rms_nt,
        "be_max_rel": None if err is None else err.max_rel,
        "be_rms_nT_lsq": None if err_l is None else err_l.rms_nt,
        "diagnosis": {"level": diag.level, "messages": list(diag.messages),
                      "sigma_hat_nT": _finite_or_none(diag.sigma_hat_nt),
                      "ratio": _finite_or_none(diag.ratio), "dof": diag.dof,
                      "unbounded": list(diag.unbounded),
                      "convention_rms_nT": diag.convention_rms_nt,
                      "best_convention": diag.best_convention,
                      "suggested_convention": diag.suggested_convention,
                      "suggested_be_nT": None if diag.suggested_be is None else list(diag.suggested_be),
                      "hint": _hint(diag, sigma_nt)},
    }


def _hint(diag, sigma_nt):
    """The options to rerun with, from the diagnosis (None if none)."""
    opts = []
    if diag.suggested_convention:
        opts.append(f"--convention {diag.suggested_convention}")
    if diag.suggested_be:
        opts.append("--be " + ",".join(f"{v:g}" for v in diag.suggested_be))
    if not opts and diag.level == "warning" and np.isfinite(diag.ratio) and diag.ratio > diag.threshold:
        opts.append(f"--sigma-nt {diag.reading_sigma_hat_nt:.3g}")
    return " ".join(opts) or None


def _print_text(r, out):
    w = lambda s="": print(s, file=out)
    mat = lambda M: "\n".join("  [" + ", ".join(f"{v:10.5f}" for v in row) + "]" for row in M)
    vec = lambda v: "[" + ", ".join(f"{x:.1f}" for x in v) + "] nT"
    nt = lambda v: "—" if v is None else f"{v:.1f} nT"
    w(f"{r['n_attitudes']} attitudes, Be = {vec(r['be_nT'])}, convention {r['convention']!r}")
    w(f"rank of Γ: {r['rank']} of 12")
    for d in r["unobservable"]:
        w(f"  unobservable: {d}")
    w(f"Kalman filter ({r['kalman']['iterations']} iterations, σ = {r['kalman']['sigma_nT']:g} nT):")
    w("K =\n" + mat(r["K"]))
    w("Bp = " + vec(r["Bp"]))
    w("least squares" + ("" if r["lsq_unique"] else " (not unique: minimum-norm solution)") + ":")
    w("K =\n" + mat(r["K_lsq"]))
    w("Bp = " + vec(r["Bp_lsq"]) + f"   (residual RMS {r['residual_rms_nT_lsq']:.1f} nT)")
    n = r["crlb_noise"]
    bounds = lambda crlb: "  " + ", ".join(  # noqa: E731
        f"{c} {'∞' if v is None else f'{v:.3g}'}{' nT' if c.startswith('Bp') else ''}"
        for c, v in crlb.items())
    w(f"CRLB (1σ) for σ_B = {n['sigma_nT']:.4g} nT, σ_angle = {n['angle_sigma_deg']:.4g}°:")
    w(bounds(r["crlb"]))
    f = r["crlb_from_residuals"]
    if f is not None:
        big = f["ratio"] > 1
        w(f"CRLB (1σ) for σ_B = {f['sigma_nT']:.3g} nT, estimated from the residuals (the stated "
          f"{n['sigma_nT']:.4g} nT is about {f['ratio'] if big else 1 / f['ratio']:.2g}× too "
          f"{'small' if big else 'large'}):")
        w(bounds(f["crlb"]))
    if r["be_max_rel"] is None:
        w("geomagnetic solution Be = (K A)⁻¹ (B − Bp): none (K is not invertible)")
    else:
        w(f"geomagnetic solution Be = (K A)⁻¹ (B − Bp): RMS error {nt(r['be_rms_nT'])} per component "
          f"(Kalman), {nt(r['be_rms_nT_lsq'])} (least squares); largest relative error "
          f"{100 * r['be_max_rel']:.2f} %")
    d = r["diagnosis"]
    for m in d["messages"]:
        w(f"{'warning' if d['level'] in ('misfit', 'warning') else 'note'}: {m}")
    if d["hint"]:
        w(f"hint: rerun with {d['hint']}")


def _parser():
    p = _Parser(
        prog=PROG,
        description="Calibrate a ship magnetometer (seed 004): K and Bp by Kalman filter and least "
                    "squares, the rank of Γ, the CRLB, the geomagnetic-solution error, and in "
                    "words whatever makes them untrustworthy (a misfit, a rank below 12).",
        epilog=f"Limits: a CSV of at most {MAX_CSV_ROWS:,} readings and {MAX_CSV_BYTES // 2 ** 20} "
               "MiB. Any bad input or option: one line on stderr, exit code 2.")
    p.add_argument("csv", metavar="DATA.csv", help="columns B1,B2,B3 (nT), psi,theta,phi (rad)")
    p.add_argument("--be", required=True, help="geomagnetic field north,east,down in nT")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--sigma-nt", type=float, default=100.0,
                   help=f"reading noise σ (nT, {NOISE_RANGE_NT[0]:g} to {NOISE_RANGE_NT[1]:g}) for "
                        "the filter, the CRLB and the misfit check (default 100)")
    p.add_argument("--angle-sigma-deg", type=float, default=0.0,
                   help="angle error σ (deg, 0 to 11.5) for the CRLB and the misfit check "
                        "(default 0)")
    p.add_argument("--iterations", type=int, default=None,
                   help=f"Kalman steps, readings reused cyclically, 1 to {MAX_KALMAN_ITERATIONS:,} "
                        "(default 50 passes, fewer for long logs, at least one pass)")
    p.add_argument("--convention", default="seed004", choices=list(CONVENTIONS))
    return p


def main(argv=None):
    """``python -m core.calibration DATA.csv --be BX,BY,BZ [--json]``; returns the exit code."""
    try:
        a = _parser().parse_args(argv)
        be = _parse_be(a.be)
        sigma = checked_noise("--sigma-nt", a.sigma_nt)
        angle_sigma = checked_angle_noise("--angle-sigma-deg", a.angle_sigma_deg, unit="deg")
        if a.iterations is not None:
            integer("--iterations", a.iterations, 1, MAX_KALMAN_ITERATIONS)
        B, att = read_attitude_csv(a.csv)
        iters = default_iterations(att.shape[0]) if a.iterations is None else a.iterations
        r = _cli_result(B, att, be, sigma_nt=sigma, angle_sigma_deg=angle_sigma,
                        iterations=iters, convention=a.convention)
    except ValueError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"{PROG}: error: not enough memory for this log; the limits are {MAX_CSV_ROWS:,} "
              "readings and the default iterations", file=sys.stderr)
        return 2
    if a.json:
        print(json.dumps(r, indent=1, allow_nan=False))
    else:
        _print_text(r, sys.stdout)
    return 0
