"""The measurement model B = K · A(ψ, θ, φ) · Be + Bp (seed 004, eq. (1); spec §9).

A is the rotation from the earth frame (x north, y east, z down) to the ship frame (x bow, y
starboard, z keel) by heading ψ, roll θ and pitch φ (rad), in one of the attitude
:data:`CONVENTIONS`; B is linear in the 12 coefficients (K, Bp), so the design rows C(n) and Γ
here are everything the observability and the estimators need.
"""

from __future__ import annotations

import numpy as np

from .validation import _K, ANGLE_LIMIT, _array, _attitudes, _vector3, checked_be

#: The 12 coefficients in the order of Γ's columns and of every 12-vector here: K row by row,
#: then Bp. (Seed 004's state x = [K Bp]ᵀ is 4 × 3: its column i is ``[k_i1, k_i2, k_i3, Bp_i]``.)
COEFFICIENTS = ("k11", "k12", "k13", "k21", "k22", "k23", "k31", "k32", "k33", "Bp1", "Bp2", "Bp3")
#: Units of :data:`COEFFICIENTS` ("1": dimensionless).
COEFFICIENT_UNITS = ("1",) * 9 + ("nT",) * 3
#: Rows per block where a computation over the readings builds per-attitude 3 × 3 (× 3) arrays:
#: the temporaries stay ~10 MB whatever N, so memory is the inputs' plus O(1).
CHUNK = 1 << 15

# Elementary passive rotations (earth → body components): R_z(a) turns the x axis towards y.
_AXES = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}


def _rotation(axis, a, derivative=True):
    """Passive rotation about ``axis`` by ``a`` (rad) and its derivative (None unless
    ``derivative``); shapes (..., 3, 3)."""
    i, j = _AXES[axis]
    k = 3 - i - j
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(np.shape(a) + (3, 3))
    R[..., k, k] = 1.0
    R[..., i, i] = R[..., j, j] = c
    R[..., i, j], R[..., j, i] = s, -s
    if not derivative:
        return R, None
    dR = np.zeros_like(R)
    dR[..., i, i] = dR[..., j, j] = -s
    dR[..., i, j], dR[..., j, i] = c, -c
    return R, dR


#: Attitude conventions: the factors of A from left to right, each (axis, angle index, sign),
#: angle index 0 = ψ (heading), 1 = θ (roll), 2 = φ (pitch); the factor is R_axis(sign · angle),
#: R the passive rotation [[c, s, 0], [−s, c, 0], [0, 0, 1]] (shown for z). ``"seed004"`` is
#: eq. (2) of seed 004 as printed, whose first factor [[cφ, 0, sφ], [0, 1, 0], [−sφ, 0, cφ]] is
#: R_y(−φ); the others are the plausible alternatives compared in docs/calibration.md.
CONVENTIONS = {
    "seed004": (("y", 2, -1.0), ("x", 1, 1.0), ("z", 0, 1.0)),
    "seed004_std_pitch": (("y", 2, 1.0), ("x", 1, 1.0), ("z", 0, 1.0)),
    "zyx": (("x", 1, 1.0), ("y", 2, 1.0), ("z", 0, 1.0)),
    "zyx_seed004_pitch": (("x", 1, 1.0), ("y", 2, -1.0), ("z", 0, 1.0)),
}


def _convention(name):
    if not isinstance(name, str) or name not in CONVENTIONS:
        raise ValueError(f"convention must be one of {list(CONVENTIONS)}; got {name!r}")
    return CONVENTIONS[name]


def attitude_matrix(attitudes, *, convention="seed004"):
    """Rotation A(ψ, θ, φ) from the earth frame to the ship frame.

    Parameters
    ----------
    attitudes : array_like, shape (..., 3)
        Heading ψ, roll θ, pitch φ (rad), |angle| ≤ 2π.
    convention : str
        A key of :data:`CONVENTIONS`; default ``"seed004"``, seed 004's eq. (2) with its Table 1's
        angle names.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Orthogonal, det = +1 (dimensionless).

    Notes
    -----
    ``"seed004"``: A = [[cφ, 0, sφ], [0, 1, 0], [−sφ, 0, cφ]] · [[1, 0, 0], [0, cθ, sθ],
    [0, −sθ, cθ]] · [[cψ, sψ, 0], [−sψ, cψ, 0], [0, 0, 1]] (seed 004, eq. (2)). ψ is measured
    clockwise from north (Table 1: east = π/2), so at ψ = π/2 the bow sensor reads Be's east
    component.

    Examples
    --------
    >>> import numpy as np, core
    >>> A = core.attitude_matrix([np.pi / 2, 0, 0])
    >>> np.round(A @ [34425, 1961, 35898]).tolist()
    [1961.0, -34425.0, 35898.0]
    """
    factors = _convention(convention)
    att = _array("attitudes", attitudes, "shape (..., 3): ψ, θ, φ in rad")
    if att.shape[-1:] != (3,):
        raise ValueError(f"attitudes must have shape (..., 3): [ψ, θ, φ] in rad; got shape {att.shape}")
    if (np.abs(att) > ANGLE_LIMIT).any():
        raise ValueError("attitudes must be in radians with |angle| ≤ 2π (degrees given by mistake?)")
    return _attitude(att, factors, derivative=False)[0]


def _attitude(att, factors, derivative=True):
    """A and dA/d(ψ, θ, φ) for valid ``att`` (..., 3): shapes (..., 3, 3) and (..., 3, 3, 3),
    the derivative's first trailing axis being the angle (None unless ``derivative``)."""
    mats = [_rotation(ax, sg * att[..., k], derivative) for ax, k, sg in factors]
    A = mats[0][0]
    for R, _ in mats[1:]:
        A = A @ R
    if not derivative:
        return A, None
    dA = np.zeros(att.shape[:-1] + (3, 3, 3))
    for f, (ax, k, sg) in enumerate(factors):
        D = None
        for g, (R, dR) in enumerate(mats):
            M = sg * dR if g == f else R
            D = M if D is None else D @ M
        dA[..., k, :, :] += D
    return A, dA


def ship_field(K, Bp, attitudes, be, *, convention="seed004"):
    """Magnetometer readings B = K · A(ψ, θ, φ) · Be + Bp (seed 004, eq. (1)).

    Parameters
    ----------
    K : array_like, shape (3, 3)
        Induced-interference matrix (dimensionless).
    Bp : array_like, shape (3,)
        Permanent-interference vector (nT).
    attitudes : array_like, shape (..., N, 3)
        ψ, θ, φ (rad).
    be : array_like, shape (3,)
        Geomagnetic field, earth frame (north, east, down), nT.
    convention : str
        See :func:`attitude_matrix`.

    Returns
    -------
    ndarray, shape (..., N, 3)
        B (nT) in the ship frame.

    Examples
    --------
    >>> import numpy as np, core
    >>> B = core.ship_field(np.eye(3), [0, 0, 0], [[0, 0, 0]], [34425, 1961, 35898])
    >>> B.tolist()
    [[34425.0, 1961.0, 35898.0]]
    """
    K, Bp = _K(K), _vector3("Bp", Bp, "nT")
    if K.shape != (3, 3):
        raise ValueError(f"K must have shape (3, 3); got {K.shape}")
    h = _body_field(_attitudes(attitudes), checked_be(be), _convention(convention))
    return h @ K.T + Bp


def _body_field(att, be, factors):
    """A(n) Be, shape (..., N, 3) (nT), computed in blocks of :data:`CHUNK` attitudes so that the
    per-attitude rotation matrices never exist for all N at once."""
    flat = att.reshape(-1, 3)
    h = np.empty(flat.shape)
    for a in range(0, flat.shape[0], CHUNK):
        h[a:a + CHUNK] = _attitude(flat[a:a + CHUNK], factors, derivative=False)[0] @ be
    return h.reshape(att.shape)


def design_rows(attitudes, be, *, convention="seed004"):
    """Seed 004's measurement rows C(n) = [Beᵀ Aᵀ(n), 1], stacked.

    Parameters
    ----------
    attitudes, be, convention
        As for :func:`ship_field`.

    Returns
    -------
    ndarray, shape (..., N, 4)
        Columns in nT, nT, nT, 1: each sensor axis i reads ``C(n) · [k_i1, k_i2, k_i3, Bp_i]``.
    """
    h = _body_field(_attitudes(attitudes), checked_be(be), _convention(convention))
    return np.concatenate([h, np.ones(h.shape[:-1] + (1,))], axis=-1)


def calibration_gamma(attitudes, be, *, convention="seed004"):
    """Observability matrix Γ of the 12 coefficients over a manoeuvre.

    Parameters
    ----------
    attitudes, be, convention
        As for :func:`ship_field`.

    Returns
    -------
    ndarray, shape (..., 3·N, 12)
        ∂B/∂(coefficients), rows attitude-major then sensor axis (B1, B2, B3), columns in the
        order of :data:`COEFFICIENTS` (units nT per coefficient unit). B is linear in the
        coefficients, so Γ does not depend on them.
    """
    C = design_rows(attitudes, be, convention=convention)  # (..., N, 4)
    lead, N = C.shape[:-2], C.shape[-2]
    G = np.zeros(lead + (N, 3, 12))
    for i in range(3):
        G[..., i, 3 * i:3 * i + 3] = C[..., :3]  # dB_i/dk_ij = (A Be)_j
        G[..., i, 9 + i] = 1.0  # dB_i/dBp_i
    return G.reshape(lead + (3 * N, 12))

