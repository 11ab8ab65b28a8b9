"""The field models of spec §2 written out in sympy, independently of :mod:`core`.

Used by :mod:`paper.precision` (60-digit evidence) and by the tests as the reference that core's
hand-derived Jacobians are checked against.
"""

from __future__ import annotations

import sympy as sp

X = sp.symbols("x y z vx vy Ph Pv", real=True)
S = sp.symbols("sx sy sz", real=True)
SIGMA = sp.Symbol("sigma", positive=True)


def field_expressions(model):
    """(Ex, Ey, Ez) at station S for state X as sympy expressions (spec §2)."""
    x, y, z, vx, vy, ph, pv = X
    theta = sp.atan2(vy, vx)
    k = 1 / (4 * sp.pi * SIGMA)
    if model == "exact":
        R = sp.Matrix([S[0] - x, S[1] - y, S[2] - z])  # station − target
        D = sp.sqrt(R.dot(R))
        p = sp.Matrix([ph * sp.cos(theta), ph * sp.sin(theta), pv])
        return tuple(k * (3 * p.dot(R) * R / D**5 - p / D**3))
    a, b, c = x - S[0], y - S[1], z - S[2]  # eqs. (10)–(12) as printed
    D = sp.sqrt(a**2 + b**2 + c**2)
    ct, st = sp.cos(theta), sp.sin(theta)
    ex = k * (ph * ct * (3 * a**2 - D**2) / D**5 - ph * st * 3 * a * b / D**5 + pv * 3 * a * c / D**5)
    ey = k * (ph * st * (3 * a**2 - D**2) / D**5 + ph * ct * 3 * a * b / D**5 + pv * 3 * b * c / D**5)
    ez = k * (ph * 3 * a * c / D**5 + pv * (3 * c**2 - D**2) / D**5)
    return ex, ey, ez
