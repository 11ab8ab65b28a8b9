"""Make tests/data/calibration_reference.json: seed 004's cases as the calibration code computed them.

The file pins the answers of ``core``'s calibration functions on seed 004's cases (Table 1, its
simulation, four level headings, headings with roll and pitch) so that a rewrite of the
algorithms (thin factorizations instead of full SVDs, chunked sums) can be checked against the
previous code to 1e-10 (tests/test_calibration_scaling.py). The committed file was made at
commit 47b19e9, before that rewrite (``core/calibration.py`` as one module, full SVDs of Γ).
Inputs (readings and attitudes) are stored with the outputs, so the check does not depend on
numpy's random streams. Run from the repository root:

    python -m tests.create_data.make_calibration_reference
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

import core

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "tests" / "data" / "calibration_reference.json"
#: Kalman iterations whose state is stored (the filter runs 600 steps, as the CLI's default for
#: 12 attitudes and the tab's presets).
KEPT = (0, 1, 2, 3, 5, 8, 12, 20, 50, 100, 200, 300, 450, 600)


def _cases():
    sim = core.SEED004_SIMULATION
    K, Bp, be_sim = np.array(sim["K"]), np.array(sim["Bp"]), np.array(sim["be"])
    sig_sim, sig_a = 100.0 / np.sqrt(3), np.deg2rad(0.05) / np.sqrt(3)
    B, att = core.seed004_table1()
    yield "table1", dict(B=B, att=att, nominal=att, be=np.array(core.SEED004_TABLE1["be"]),
                         sigma=100.0, angle_sigma=0.0, K_lin=None, Q=None)
    rng = np.random.default_rng(4)
    att = core.random_attitudes(12, rng)
    B, rec = core.simulate_ship_data(K, Bp, att, be_sim, rng, noise_nt=100, angle_noise_deg=0.05)
    yield "simulation", dict(B=B, att=rec, nominal=att, be=be_sim, sigma=sig_sim,
                             angle_sigma=sig_a, K_lin=K, Q=None)
    yield "simulation_q", dict(B=B, att=rec, nominal=att, be=be_sim, sigma=sig_sim,
                               angle_sigma=sig_a, K_lin=K, Q=(1e-8, 1e-8, 1e-8, 1.0))
    rng = np.random.default_rng(7)
    att = core.level_headings()
    B, rec = core.simulate_ship_data(K, Bp, att, be_sim, rng, noise_nt=100)
    yield "four_level", dict(B=B, att=rec, nominal=att, be=be_sim, sigma=sig_sim,
                             angle_sigma=sig_a, K_lin=K, Q=None)
    rng = np.random.default_rng(8)
    att = core.heading_manoeuvre(roll_deg=10, pitch_deg=5, n_attitudes=12)
    B, rec = core.simulate_ship_data(K, Bp, att, be_sim, rng, noise_nt=100, angle_noise_deg=0.05)
    yield "roll_pitch", dict(B=B, att=rec, nominal=att, be=be_sim, sigma=sig_sim,
                             angle_sigma=sig_a, K_lin=K, Q=None)


def _case(c):
    be, nominal = c["be"], c["nominal"]
    obs = core.calibration_observability(nominal, be)
    kw = dict(noise_nt=c["sigma"], angle_noise_rad=c["angle_sigma"], K=c["K_lin"])
    crlb = core.calibration_crlb(nominal, be, **kw)
    cov_crlb = core.calibration_covariance(nominal, be, **kw)
    cov_lsq = core.calibration_covariance(nominal, be, estimator="lsq", **kw)
    lsq = core.lsq_calibrate(c["B"], c["att"], be)
    kal = core.kalman_calibrate(c["B"], c["att"], be, sigma_nt=c["sigma"], iterations=600, Q=c["Q"])
    conv = int(core.convergence_iteration(kal.coefficients, crlb))
    est = core.geomagnetic_solution(c["B"], c["att"], kal.K, kal.Bp)
    err_k = core.geomagnetic_error(est, be)
    err_l = core.geomagnetic_error(core.geomagnetic_solution(c["B"], c["att"], lsq.K, lsq.Bp), be)
    conv_rms = {name: float(core.lsq_calibrate(c["B"], c["att"], be, convention=name).residual_rms_nt)
                for name in core.CONVENTIONS}
    return {
        "inputs": {"B": c["B"].tolist(), "attitudes": c["att"].tolist(), "nominal": nominal.tolist(),
                   "be": be.tolist(), "sigma_nt": c["sigma"], "angle_sigma_rad": c["angle_sigma"],
                   "K_lin": None if c["K_lin"] is None else c["K_lin"].tolist(),
                   "Q": None if c["Q"] is None else list(c["Q"])},
        "observability": {"rank": obs.rank, "singular_values": obs.singular_values.tolist(),
                          "null_directions": obs.null_directions.tolist(),
                          "descriptions": list(obs.descriptions),
                          "observable": obs.observable.tolist(), "condition": obs.condition},
        "crlb": crlb.tolist(), "cov_crlb": cov_crlb.tolist(), "cov_lsq": cov_lsq.tolist(),
        "lsq": {"K": lsq.K.tolist(), "Bp": lsq.Bp.tolist(), "rank": lsq.rank,
                "residual_rms_nt": float(lsq.residual_rms_nt)},
        "lsq_residual_rms_by_convention": conv_rms,
        "kalman": {"kept": list(KEPT), "history": kal.history[list(KEPT)].tolist(),
                   "P_diag": kal.P_diag[list(KEPT)].tolist(), "convergence_iteration": conv},
        "be_hat_kalman": est.tolist(),
        "be_error_kalman": [err_k.rms_nt, err_k.vector_rms_nt, err_k.max_rel],
        "be_error_lsq": [err_l.rms_nt, err_l.vector_rms_nt, err_l.max_rel],
    }


def _cli_table1():
    out = subprocess.run([sys.executable, "-m", "core.calibration", "data/seed004_table1.csv",
                          "--be", "34425,1961,35898", "--json"], cwd=ROOT, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout)


def main():
    ref = {name: _case(c) for name, c in _cases()}
    ref["cli_table1"] = _cli_table1()
    OUT.write_text(json.dumps(ref, indent=None, separators=(",", ":")) + "\n")
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
