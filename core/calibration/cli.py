"""``python -m core.calibration DATA.csv --be BX,BY,BZ``: calibrate from a CSV log.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from .data import read_attitude_csv
from .estimators import DEFAULT_P0_DIAG, kalman_calibrate, lsq_calibrate
from .geomagnetic import geomagnetic_error, geomagnetic_solution
from .model import COEFFICIENTS, CONVENTIONS
from .observability import calibration_crlb, calibration_observability
from .validation import _positive


def _parse_be(text):
    parts = text.replace("−", "-").split(",")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != 3 or not all(np.isfinite(vals)) or not any(vals):
        raise ValueError(f"--be must be three comma-separated numbers in nT (north, east, down), "
                         f"e.g. --be 34425,1961,35898; got {text!r}")
    return np.array(vals)


def _cli_result(B, att, be, *, sigma_nt, angle_sigma_deg, iterations, convention):
    lsq = lsq_calibrate(B, att, be, convention=convention)
    kal = kalman_calibrate(B, att, be, sigma_nt=sigma_nt, iterations=iterations,
                           convention=convention)
    obs = calibration_observability(att, be, convention=convention)
    crlb = calibration_crlb(att, be, noise_nt=sigma_nt, angle_noise_rad=np.deg2rad(angle_sigma_deg),
                            K=lsq.K, convention=convention)
    K, Bp = kal.K, kal.Bp
    use_lsq = obs.rank == 12
    err = geomagnetic_error(geomagnetic_solution(B, att, K, Bp, convention=convention), be)
    err_l = geomagnetic_error(geomagnetic_solution(B, att, lsq.K, lsq.Bp, convention=convention), be)
    fin = lambda v: None if not np.isfinite(v) else float(v)
    return {
        "convention": convention, "n_attitudes": int(att.shape[0]), "be_nT": be.tolist(),
        "K": K.tolist(), "Bp": Bp.tolist(), "K_lsq": lsq.K.tolist(), "Bp_lsq": lsq.Bp.tolist(),
        "lsq_unique": use_lsq, "residual_rms_nT_lsq": float(lsq.residual_rms_nt),
        "rank": obs.rank, "unobservable": list(obs.descriptions),
        "crlb": {c: fin(s) for c, s in zip(COEFFICIENTS, crlb)},
        "crlb_noise": {"sigma_nT": sigma_nt, "angle_sigma_deg": angle_sigma_deg},
        "kalman": {"iterations": iterations, "sigma_nT": sigma_nt, "x0": "zero",
                   "P0_diag": list(DEFAULT_P0_DIAG), "Q": 0.0},
        "be_rms_nT": err.rms_nt, "be_vector_rms_nT": err.vector_rms_nt, "be_max_rel": err.max_rel,
        "be_rms_nT_lsq": err_l.rms_nt,
    }


def _print_text(r, out):
    w = lambda s="": print(s, file=out)
    mat = lambda M: "\n".join("  [" + ", ".join(f"{v:10.5f}" for v in row) + "]" for row in M)
    vec = lambda v: "[" + ", ".join(f"{x:.1f}" for x in v) + "] nT"
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
    w(f"CRLB (1σ) for σ_B = {n['sigma_nT']:g} nT, σ_angle = {n['angle_sigma_deg']:g}°:")
    w("  " + ", ".join(f"{c} {'∞' if v is None else f'{v:.3g}'}{' nT' if c.startswith('Bp') else ''}"
                       for c, v in r["crlb"].items()))
    w(f"geomagnetic solution Be = (K A)⁻¹ (B − Bp): RMS error {r['be_rms_nT']:.1f} nT per component "
      f"(Kalman), {r['be_rms_nT_lsq']:.1f} nT (least squares); largest relative error "
      f"{100 * r['be_max_rel']:.2f} %")


def main(argv=None):
    """``python -m core.calibration DATA.csv --be BX,BY,BZ [--json]``; returns the exit code."""
    p = argparse.ArgumentParser(
        prog="python -m core.calibration",
        description="Calibrate a ship magnetometer (seed 004): K and Bp by Kalman filter and least "
                    "squares, the rank of Γ, the CRLB and the geomagnetic-solution error.")
    p.add_argument("csv", metavar="DATA.csv", help="columns B1,B2,B3 (nT), psi,theta,phi (rad)")
    p.add_argument("--be", required=True, help="geomagnetic field north,east,down in nT")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--sigma-nt", type=float, default=100.0,
                   help="reading noise σ (nT) for the filter and the CRLB (default 100)")
    p.add_argument("--angle-sigma-deg", type=float, default=0.0,
                   help="angle error σ (deg) for the CRLB (default 0)")
    p.add_argument("--iterations", type=int, default=None,
                   help="Kalman steps, readings reused cyclically (default 50 passes)")
    p.add_argument("--convention", default="seed004", choices=list(CONVENTIONS))
    a = p.parse_args(argv)
    try:
        be = _parse_be(a.be)
        _positive("--sigma-nt", a.sigma_nt, "nT")
        _positive("--angle-sigma-deg", a.angle_sigma_deg, "deg", allow_zero=True)
        B, att = read_attitude_csv(a.csv)
        iters = 50 * att.shape[0] if a.iterations is None else a.iterations
        if iters < 1:
            raise ValueError(f"--iterations must be ≥ 1; got {iters}")
        r = _cli_result(B, att, be, sigma_nt=a.sigma_nt, angle_sigma_deg=a.angle_sigma_deg,
                        iterations=iters, convention=a.convention)
    except ValueError as exc:
        print(f"python -m core.calibration: error: {exc}", file=sys.stderr)
        return 2
    if a.json:
        print(json.dumps(r, indent=1, allow_nan=False))
    else:
        _print_text(r, sys.stdout)
    return 0


