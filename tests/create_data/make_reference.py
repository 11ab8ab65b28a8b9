"""Make tests/data/reference_logdet.json: log10|det Γ| in 60-digit arithmetic.

Γ is built from the sympy field expressions of support/symbolic.py, differentiated
symbolically and evaluated with mpmath at 60 significant digits, its determinant taken by
mpmath. Run from the repository root:

    python -m tests.create_data.make_reference
"""

from __future__ import annotations

import json
from pathlib import Path

import mpmath as mp
import sympy as sp

from support.symbolic import SIGMA, S, X, field_expressions

mp.mp.dps = 60
OUT = Path(__file__).resolve().parents[1] / "data" / "reference_logdet.json"

CASES = [
    # (state [x, y, z, vx, vy, Ph, Pv], stations, model)
    ([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]], "exact"),
    ([-120, 75, 120, 2, 2, 100, 20], [[0, 0, 100], [2, 0, 100]], "exact"),
    ([200, -150, 160, -1.5, 3, 70.7, 70.7], [[0, 0, 100], [50, 0, 100]], "exact"),
    ([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]], "paper"),
    ([-80, 20, 300, 2, -1, 100, 100], [[0, 0, 100], [10, 0, 100]], "paper"),
    # one station: structurally singular, det Γ = 0 (spec §4)
    ([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]], "exact"),
    ([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]], "paper"),
]


def gamma_mp(state, stations, model, T=1, sigma=4):
    """Paper-rule Γ (7 × 7) as an mpmath matrix."""
    jac = sp.Matrix(field_expressions(model)).jacobian(sp.Matrix(X))
    rows = []
    n_inst = -(-7 // (3 * len(stations)))
    for i in range(n_inst):
        phi = sp.eye(7)
        phi[0, 3] = phi[1, 4] = i * T
        moved = phi * sp.Matrix([sp.Rational(str(v)) for v in state])
        for st in stations:
            subs = dict(zip(X, moved))
            subs.update(zip(S, [sp.Rational(str(v)) for v in st]))
            subs[SIGMA] = sigma
            block = (jac.subs(subs) * phi).evalf(70)
            rows.extend(block.tolist())
    return mp.matrix([[mp.mpf(str(v)) for v in row] for row in rows[:7]])


def main():
    out = []
    for state, stations, model in CASES:
        g = gamma_mp(state, stations, model)
        det = mp.det(g)
        colnorm = mp.fprod(mp.norm(g[:, j]) for j in range(7))
        out.append({
            "state": state, "stations": stations, "model": model,
            "log10_abs_det": None if det == 0 else float(mp.log10(abs(det))),
            "log10_hadamard": None if det == 0 else float(mp.log10(abs(det) / colnorm)),
            "log10_column_norm_product": float(mp.log10(colnorm)),
        })
        print(model, len(stations), out[-1]["log10_abs_det"], out[-1]["log10_hadamard"])
    OUT.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
