"""An independent reference: the spec's field models written out in sympy, differentiated
symbolically and lambdified to numpy. Used by the tests (Jacobians to ~1e-10) and by
bench/ as "the straightforward way" to compute a log10|det Γ| map.

Nothing here imports core: the formulas of spec §2 and the paper's eqs. (10)–(12) come from
:mod:`paper.symbolic`, written in sympy.
"""

from __future__ import annotations

import functools

import numpy as np
import sympy as sp

from paper.symbolic import SIGMA, S, X, field_expressions


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
