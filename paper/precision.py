"""High-precision evidence that the single-station determinant is round-off (spec §4).

Γ is rebuilt here independently of :mod:`core`'s kernels: the field formulas of spec §2 written
in sympy (:mod:`paper.symbolic`, also the test suite's reference), differentiated symbolically
and evaluated with mpmath at any number of digits.
"""

from __future__ import annotations

import functools

import mpmath as mp
import numpy as np
import sympy as sp

import core

from . import scenarios as sc
from .symbolic import SIGMA, S, X, field_expressions

#: Working precisions (significant digits) of the evidence table.
DIGITS = (50, 100)
#: float64's unit round-off.
EPS = float(np.finfo(float).eps)
#: Fig. 1 points (x, y) in m at z = 120 m.
POINTS = ((30.0, 40.0), (0.0, 0.0), (-150.0, 100.0), (300.0, 300.0))


@functools.lru_cache(maxsize=None)
def _jacobian_function(model):
    jac = sp.Matrix(field_expressions(model)).jacobian(sp.Matrix(X))
    return sp.lambdify((*X, *S, SIGMA), jac.tolist(), "mpmath")


def gamma_mp(state, stations, model, digits, steps=None):
    """Γ as an mpmath matrix at ``digits`` significant digits: the paper rule (7 × 7) for
    ``steps=None``, else all rows of ``steps`` instants ((3·S·steps) × 7)."""
    jfun = _jacobian_function(model)
    with mp.workdps(digits):
        st = [mp.mpf(repr(float(v))) for v in state]
        rows = []
        for i in range(-(-7 // (3 * len(stations))) if steps is None else steps):
            phi = mp.eye(7)
            phi[0, 3] = phi[1, 4] = i * sc.T
            moved = phi * mp.matrix(st)
            for s in stations:
                jac = mp.matrix(jfun(*moved, *[mp.mpf(repr(float(c))) for c in s], mp.mpf(sc.SIGMA)))
                block = jac * phi
                rows.extend([[block[r, c] for c in range(7)] for r in range(3)])
        return mp.matrix(rows[:7] if steps is None else rows)


def _log10_det_and_eta(g, digits):
    with mp.workdps(digits):
        det = mp.det(g)
        norms = mp.fprod(mp.norm(g[:, j]) for j in range(g.cols))
        if det == 0:
            return float("-inf"), float("-inf")
        return float(mp.log10(abs(det))), float(mp.log10(abs(det) / norms))


def null_vector(state, station):
    """The spec §4 null direction n = (x − sx, y − sy, z − sz, vx, vy, 3 Ph, 3 Pv)."""
    x = np.asarray(state, dtype=float)
    return np.r_[x[:3] - np.asarray(station, dtype=float), x[3:5], 3 * x[5:7]]


def evidence(model, points=POINTS):
    """Rows of the round-off table for one model.

    For each Fig. 1 point: the round-off scale log10(ε · Π‖Γ_j‖) of float64's det Γ and whether
    core's float64 log10|det Γ| and log10 η are within round-off (≤ that scale, ≤ log10 ε), the
    same at each of :data:`DIGITS` (mpmath), the dual (d = 15 m) log10 η in float64 and at DIGITS[0] for
    contrast, the relative null residual ‖Γ n‖ / Σ‖Γ_j‖|n_j| in float64 and at DIGITS[0],
    and |cos| between n and core.unobservable_direction.
    """
    single, dual = sc.stations(), sc.stations(sc.DUAL_D)
    kw = dict(T=sc.T, sensor=core.Sensor("E", sigma=sc.SIGMA, model=model))
    rows = []
    for x, y in points:
        state = np.array([x, y, sc.Z, *sc.VELOCITY, sc.PH, sc.PV])
        g = core.gamma(state, single, **kw)
        # float64's values are round-off: their digits differ between kernels compiled in the
        # process and loaded from numba's cache, so what is kept is the verdict that they are
        # within the round-off scale (ε · Π‖Γ_j‖ for det Γ, ε for η), by decades either way
        scale = float(np.sum(np.log10(np.linalg.norm(g, axis=0))) + np.log10(EPS))
        row = {"x": x, "y": y, "roundoff_log10_det": scale,
               "f64_det_within_roundoff": bool(core.log10_abs_det_gamma(state, single, **kw) <= scale),
               "f64_eta_within_roundoff": bool(core.observability_index(state, single, **kw) <= np.log10(EPS)),
               "dual_f64_log10_eta": float(core.observability_index(state, dual, **kw))}
        mats = {dg: gamma_mp(state, single, model, dg) for dg in DIGITS}
        for dg in DIGITS:
            row[f"mp{dg}_log10_det"], row[f"mp{dg}_log10_eta"] = _log10_det_and_eta(mats[dg], dg)
        row["dual_mp_log10_eta"] = _log10_det_and_eta(gamma_mp(state, dual, model, DIGITS[0]), DIGITS[0])[1]
        n = null_vector(state, single[0])
        row["f64_null_residual"] = float(np.linalg.norm(g @ n) / np.sum(np.linalg.norm(g, axis=0) * np.abs(n)))
        with mp.workdps(DIGITS[0]):
            gm = mats[DIGITS[0]]
            nm = mp.matrix([mp.mpf(repr(float(v))) for v in n])
            scale = mp.fsum(mp.norm(gm[:, j]) * abs(nm[j]) for j in range(7))
            row["mp_null_residual"] = float(mp.norm(gm * nm) / scale)
        u = core.unobservable_direction(state, single, **kw)
        row["cos_core_direction"] = float(abs(u @ n) / np.linalg.norm(n))
        rows.append(row)
    return rows
