"""An independent reference: the spec's field models written out in sympy, differentiated
symbolically and lambdified to numpy. Used by the tests (Jacobians to ~1e-10) and by
bench/ as "the straightforward way" to compute a log10|det Γ| map.

Nothing here imports core's kernels; only the formulas of spec §2 and the paper's eqs.
(10)–(12) are shared.
"""

from __future__ import annotations

import functools

import numpy as np
import sympy as sp

X = sp.symbols("x y z vx vy Ph Pv", real=True)
S = sp.symbols("sx sy sz", real=True)
SIGMA = sp.Symbol("sigma", positive=True)


def field_expressions(model):
    """(Ex, Ey, Ez) at station S for state X, as sympy expressions."""
    x, y, z, vx, vy, ph, pv = X
    theta = sp.atan2(vy, vx)
    k = 1 / (4 * sp.pi * SIGMA)
    if model == "exact":
        # R = station − target; E = (3 (p·R) R / D⁵ − p / D³) / (4πσ)
        R = sp.Matrix([S[0] - x, S[1] - y, S[2] - z])
        D = sp.sqrt(R.dot(R))
        p = sp.Matrix([ph * sp.cos(theta), ph * sp.sin(theta), pv])
        E = k * (3 * p.dot(R) * R / D**5 - p / D**3)
        return tuple(E)
    # The paper's eqs. (10)–(12), x, y relative to the station, (z − h) target minus station.
    a, b, c = x - S[0], y - S[1], z - S[2]
    D = sp.sqrt(a**2 + b**2 + c**2)
    ct, st = sp.cos(theta), sp.sin(theta)
    ex = k * (ph * ct * (3 * a**2 - D**2) / D**5 - ph * st * 3 * a * b / D**5 + pv * 3 * a * c / D**5)
    ey = k * (ph * st * (3 * a**2 - D**2) / D**5 + ph * ct * 3 * a * b / D**5 + pv * 3 * b * c / D**5)
    ez = k * (ph * 3 * a * c / D**5 + pv * (3 * c**2 - D**2) / D**5)
    return ex, ey, ez


@functools.lru_cache(maxsize=None)
def field_functions(model):
    """numpy functions (E, J) of (*X, *S, sigma): E (3,...) and J (3, 7, ...)."""
    exprs = sp.Matrix(field_expressions(model))
    jac = exprs.jacobian(sp.Matrix(X))
    args = (*X, *S, SIGMA)
    return sp.lambdify(args, exprs.tolist(), "numpy"), sp.lambdify(args, jac.tolist(), "numpy")


def field(states, stations, sigma=4.0, model="exact"):
    """E at every station, shape (..., S, 3), by the lambdified sympy expressions."""
    states = np.asarray(states, dtype=float)
    efun, _ = field_functions(model)
    out = []
    for st in np.asarray(stations, dtype=float):
        e = efun(*np.moveaxis(states, -1, 0), *st, sigma)  # [[Ex], [Ey], [Ez]]
        out.append(np.stack([np.broadcast_to(row[0], states.shape[:-1]) for row in e], axis=-1))
    return np.stack(out, axis=-2)


def field_jacobian(states, stations, sigma=4.0, model="exact"):
    """∂E/∂X, shape (..., S, 3, 7), by the lambdified sympy Jacobian."""
    states = np.asarray(states, dtype=float)
    _, jfun = field_functions(model)
    out = []
    for st in np.asarray(stations, dtype=float):
        j = jfun(*np.moveaxis(states, -1, 0), *st, sigma)  # nested lists of arrays / scalars
        j = np.array([[np.broadcast_to(v, states.shape[:-1]) for v in row] for row in j])
        out.append(np.moveaxis(j, (0, 1), (-2, -1)))  # (..., 3, 7)
    return np.stack(out, axis=-3)


def gamma(states, stations, *, T=1.0, sigma=4.0, model="exact", steps=None):
    """Γ assembled the straightforward way (spec §3) from the sympy Jacobian."""
    states = np.asarray(states, dtype=float)
    stations = np.asarray(stations, dtype=float)
    n_s = len(stations)
    n_inst = steps if steps is not None else -(-7 // (3 * n_s))
    blocks = []
    for i in range(n_inst):
        phi = np.eye(7)
        phi[0, 3] = phi[1, 4] = i * T
        moved = states @ phi.T  # Φ^i X
        jac = field_jacobian(moved, stations, sigma, model)  # (..., S, 3, 7)
        blocks.append(jac.reshape(states.shape[:-1] + (3 * n_s, 7)) @ phi)
    g = np.concatenate(blocks, axis=-2)
    return g[..., :7, :] if steps is None else g


def log10_abs_det_gamma(states, stations, **kw):
    """log10|det Γ| via numpy.linalg.slogdet on the straightforward Γ."""
    _, logabs = np.linalg.slogdet(gamma(states, stations, **kw))
    return logabs / np.log(10.0)
