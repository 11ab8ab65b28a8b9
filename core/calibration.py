"""Calibrating a ship's three-component magnetometer: observability and the Kalman filter of seed 004.

A magnetometer on a ship reads (seed 004, eq. (1); spec §9)

    B = K · A(ψ, θ, φ) · Be + Bp                                  (nT)

with Be the geomagnetic field in the earth frame (x north, y east, z down, nT), A the rotation
from the earth frame to the ship frame (x bow, y starboard, z keel) by heading ψ, roll θ and
pitch φ (rad), K the 3 × 3 induced-interference matrix (dimensionless) and Bp the
permanent-interference vector (nT). The twelve coefficients (K, Bp) are constant. Each attitude
gives three equations that are *linear* in them, so everything here is exact linear algebra:

- per sensor axis i, ``B_i(n) = C(n) · [k_i1, k_i2, k_i3, Bp_i]ᵀ`` with the 1 × 4 row
  ``C(n) = [Beᵀ Aᵀ(n), 1]`` of seed 004 (its eq. (6)); the three axes share C(n);
- the observability matrix Γ of the 12 coefficients over a manoeuvre (a list of attitudes) is
  ``I₃ ⊗ G`` with G the N × 4 stack of C(n) (in the coefficient order of :data:`COEFFICIENTS`),
  so rank Γ = 3 · rank G. G has full rank 4 exactly when the ship-frame field vectors
  ``A(n) Be`` are not coplanar: level headings keep them on one horizontal plane (the
  four-heading method's blind spot: K's third column and Bp cannot be told apart), and so does a
  constant heel; a roll or pitch that *varies* between attitudes tilts them off it.

The attitude convention (:data:`CONVENTIONS`): seed 004 prints A as eq. (2),
``A = R_y(−φ) · R_x(θ) · R_z(ψ)`` with R the standard passive rotations (the matrices are in
:func:`attitude_matrix`'s Notes), but its caption names φ, θ, ψ as heading, roll and pitch,
contradicting its own Table 1 (ψ takes the four heading values 0, π/2, π, 3π/2; θ is the roll of
±0.2 rad; φ the small pitch). The default ``"seed004"`` is eq. (2) with Table 1's names: the
paper's own K and Bp fit Table 1 only with eq. (2)'s sign of the pitch factor (residual RMS
454 nT, against ≥ 837 nT with the standard sign); docs/calibration.md has the comparison.

No web stack is imported here.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "ANGLE_LIMIT",
    "CAL_RANK_RTOL",
    "COEFFICIENTS",
    "COEFFICIENT_UNITS",
    "CONVENTIONS",
    "CSV_COLUMNS",
    "SEED004_SIMULATION",
    "SEED004_TABLE1",
    "CalibrationObservability",
    "GeomagneticError",
    "KalmanResult",
    "LsqResult",
    "attitude_matrix",
    "calibration_covariance",
    "calibration_crlb",
    "calibration_gamma",
    "calibration_observability",
    "design_rows",
    "geomagnetic_error",
    "geomagnetic_solution",
    "heading_manoeuvre",
    "convergence_iteration",
    "kalman_calibrate",
    "level_headings",
    "lsq_calibrate",
    "parse_attitude_csv",
    "random_attitudes",
    "read_attitude_csv",
    "seed004_table1",
    "seed004_table1_path",
    "ship_field",
    "simulate_ship_data",
]

#: The 12 coefficients in the order of Γ's columns and of every 12-vector here: K row by row,
#: then Bp. (Seed 004's state x = [K Bp]ᵀ is 4 × 3: its column i is ``[k_i1, k_i2, k_i3, Bp_i]``.)
COEFFICIENTS = ("k11", "k12", "k13", "k21", "k22", "k23", "k31", "k32", "k33", "Bp1", "Bp2", "Bp3")
#: Units of :data:`COEFFICIENTS` ("1": dimensionless).
COEFFICIENT_UNITS = ("1",) * 9 + ("nT",) * 3
#: Columns a calibration CSV must have (extra columns are ignored): B in nT, angles in rad.
CSV_COLUMNS = ("B1", "B2", "B3", "psi", "theta", "phi")
#: Largest |angle| accepted (rad). A heading of 90 means degrees were given by mistake.
ANGLE_LIMIT = 2.0 * np.pi
#: Γ (columns scaled to unit norm) has rank r when r singular values exceed CAL_RANK_RTOL times
#: the largest. Exactly confounded coefficients (level headings) give ≤ 1e-15 (round-off); a
#: roll of amplitude 0.01° (0.01°, 0, −0.01°, 0 on the four headings) already gives 2.5e-6
#: (tests/test_calibration.py), so 1e-9 separates "not determined at all" from "determined,
#: perhaps poorly" with ≥ 3 decades either side. How poorly is the CRLB's job, not the rank's.
CAL_RANK_RTOL = 1e-9

# Elementary passive rotations (earth → body components): R_z(a) turns the x axis towards y.
_AXES = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}


def _rotation(axis, a):
    """Passive rotation about ``axis`` by ``a`` (rad) and its derivative; shapes (..., 3, 3)."""
    i, j = _AXES[axis]
    k = 3 - i - j
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(np.shape(a) + (3, 3))
    dR = np.zeros_like(R)
    R[..., k, k] = 1.0
    R[..., i, i] = R[..., j, j] = c
    R[..., i, j], R[..., j, i] = s, -s
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

#: Seed 004's simulation (§2.2): Be (nT), K, Bp (nT), attitude ranges (deg), 12 attitudes, and
#: its errors "of at most" 100 nT on B and 0.05° on each angle (modelled as uniform, see
#: :func:`simulate_ship_data`), and the estimate it reports.
SEED004_SIMULATION = {
    "be": (34000.0, 2000.0, 35000.0),
    "K": ((0.95, -0.003, 0.003), (0.003, 0.95, -0.03), (0.03, -0.03, 1.05)),
    "Bp": (1500.0, -800.0, 1800.0),
    "heading_deg": (0.0, 360.0), "roll_deg": (-20.0, 20.0), "pitch_deg": (-15.0, 15.0),
    "n_attitudes": 12, "noise_nt": 100.0, "angle_noise_deg": 0.05,
    "paper_K": ((0.9499, -0.0036, 0.0030), (0.0027, 0.9502, -0.0303), (0.0295, -0.0296, 1.0499)),
    "paper_Bp": (1497.0, -809.0, 1806.0),
    "paper_iterations": 300,
}
#: Seed 004's ship-model experiment (§3, Table 1): Be (nT) and the K, Bp (nT) it reports, and
#: the RMS error (nT) and largest relative error of its geomagnetic solution.
SEED004_TABLE1 = {
    "be": (34425.0, 1961.0, 35898.0),
    "paper_K": ((0.98575, 0.08153, 0.06221), (-0.06233, 0.83517, -0.02987),
                (-0.02999, -0.07748, 1.06615)),
    "paper_Bp": (2011.1, -2886.8, 2054.6),
    "paper_be_rms_nt": 266.0, "paper_be_max_rel": 0.019,
}


# --------------------------------------------------------------------------- validation
def _array(name, value, what):
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array ({what}): {exc}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite ({what}); NaN and inf are not accepted")
    return arr


def _attitudes(value, name="attitudes"):
    arr = _array(name, value, "shape (..., N, 3): heading ψ, roll θ, pitch φ in rad")
    if arr.ndim < 2 or arr.shape[-1] != 3 or arr.shape[-2] < 1:
        raise ValueError(f"{name} must have shape (..., N, 3) with N ≥ 1 rows of [ψ, θ, φ] in rad; "
                         f"got shape {arr.shape}")
    big = np.abs(arr) > ANGLE_LIMIT
    if big.any():
        raise ValueError(f"{name} must be in radians with |angle| ≤ 2π; got {arr[big].flat[0]:g} "
                         "(degrees given by mistake? multiply by π/180)")
    return arr


def _vector3(name, value, unit):
    arr = _array(name, value, f"3 components in {unit}")
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a vector of 3 components in {unit}; got shape {arr.shape}")
    return arr


def _be(value):
    be = _vector3("be", value, "nT")
    if not np.linalg.norm(be) > 0:
        raise ValueError("be (the geomagnetic field, nT) must not be zero")
    return be


def _K(value):
    K = _array("K", value, "3 × 3, dimensionless")
    if K.shape[-2:] != (3, 3):
        raise ValueError(f"K must have shape (..., 3, 3) (dimensionless); got shape {K.shape}")
    return K


def _convention(name):
    if name not in CONVENTIONS:
        raise ValueError(f"convention must be one of {list(CONVENTIONS)}; got {name!r}")
    return CONVENTIONS[name]


def _readings(B, attitudes):
    B = _array("B", B, "shape (..., N, 3) in nT")
    if B.shape[-1:] != (3,) or B.ndim < 2 or B.shape[-2] != attitudes.shape[-2]:
        raise ValueError(f"B must have shape (..., N, 3) in nT with one row per attitude "
                         f"(N = {attitudes.shape[-2]}); got shape {B.shape}")
    return B


def _positive(name, value, unit, allow_zero=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number {'≥' if allow_zero else '>'} 0 ({unit}); "
                         f"got {value!r}") from None
    if not (np.isfinite(v) and (v >= 0 if allow_zero else v > 0)):
        raise ValueError(f"{name} must be a finite number {'≥' if allow_zero else '>'} 0 ({unit}); "
                         f"got {value!r}")
    return v


# --------------------------------------------------------------------------- model
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
    return _attitude(att, factors)[0]


def _attitude(att, factors):
    """A and dA/d(ψ, θ, φ) for valid ``att`` (..., 3): shapes (..., 3, 3) and (..., 3, 3, 3),
    the derivative's first trailing axis being the angle."""
    mats = [_rotation(ax, sg * att[..., k]) for ax, k, sg in factors]
    A = mats[0][0]
    for R, _ in mats[1:]:
        A = A @ R
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
    h = _body_field(_attitudes(attitudes), _be(be), _convention(convention))
    return h @ K.T + Bp


def _body_field(att, be, factors):
    """A(n) Be, shape (..., N, 3) (nT)."""
    return _attitude(att, factors)[0] @ be


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
    h = _body_field(_attitudes(attitudes), _be(be), _convention(convention))
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


# --------------------------------------------------------------------------- observability
@dataclass(frozen=True)
class CalibrationObservability:
    """What a manoeuvre determines (:func:`calibration_observability`).

    Attributes
    ----------
    rank : int
        Rank of Γ (0…12), a multiple of 3.
    singular_values : ndarray, shape (12,)
        Of the column-scaled Γ, relative to the largest (descending).
    null_directions : ndarray, shape (12 − rank, 12)
        Orthonormal basis (in column-scaled coordinates, returned in physical units) of the
        coefficient changes that leave every reading unchanged.
    descriptions : tuple of str
        Each unobservable direction in words (one per direction of a single sensor axis; the
        same holds for each of the three axes).
    observable : ndarray of bool, shape (12,)
        Which coefficients are determined (orthogonal to every null direction).
    condition : float
        Condition number of the column-scaled Γ (inf when rank < 12).
    """

    rank: int
    singular_values: np.ndarray
    null_directions: np.ndarray
    descriptions: tuple
    observable: np.ndarray
    condition: float


_AXIS_NAMES = ("K's first column", "K's second column", "K's third column", "Bp")


def _scaled_svd(G, rtol):
    scale = np.linalg.norm(G, axis=-2)
    scale = np.where(scale > 0, scale, 1.0)
    U, s, Vt = np.linalg.svd(G / scale, full_matrices=True)
    rank = int(np.sum(s > rtol * s[0])) if s[0] > 0 else 0
    return scale, s, Vt, rank


def _rref(M, tol=1e-9):
    """Reduced row echelon form of the rows of M (a sparse basis of their span)."""
    M = M.copy()
    r = 0
    for c in range(M.shape[1]):
        if r == M.shape[0]:
            break
        p = r + int(np.argmax(np.abs(M[r:, c])))
        if abs(M[p, c]) < tol:
            continue
        M[[r, p]] = M[[p, r]]
        M[r] /= M[r, c]
        for q in range(M.shape[0]):
            if q != r:
                M[q] -= M[q, c] * M[r]
        r += 1
    M[np.abs(M) < tol] = 0.0
    return M


def _describe(v):
    """Words for a per-axis null vector v = (δk_i1, δk_i2, δk_i3, δBp_i) in physical units."""
    idx = [j for j in range(4) if v[j] != 0]
    names = [_AXIS_NAMES[j] for j in idx]
    if len(idx) == 1:
        return (f"{names[0]} is not determined: for each sensor axis i, changing "
                f"{_coef(idx[0])} leaves every reading unchanged")
    lead = idx[0]
    v = v / v[lead]
    terms = [f"{_coef(j)} by {_num(v[j])}{' nT' if j == 3 else ''}·δ" for j in idx]
    joined = ", ".join(names[:-1]) + " and " + names[-1]
    return (f"{joined} cannot be told apart: for each sensor axis i, changing " + ", ".join(terms)
            + " leaves every reading unchanged")


def _coef(j):
    return "Bp_i" if j == 3 else f"k_i{j + 1}"


def _num(x):
    return "+1" if x == 1 else f"{x:+.6g}".replace("-", "−")


def calibration_observability(attitudes, be, *, convention="seed004", rtol=CAL_RANK_RTOL):
    """Rank of Γ and the unobservable coefficient combinations of a manoeuvre.

    Parameters
    ----------
    attitudes : array_like, shape (N, 3)
        ψ, θ, φ (rad).
    be : array_like, shape (3,)
        Geomagnetic field (nT).
    convention : str
        See :func:`attitude_matrix`.
    rtol : float
        Relative singular-value tolerance of the column-scaled Γ (default :data:`CAL_RANK_RTOL`).

    Returns
    -------
    CalibrationObservability

    Notes
    -----
    Γ = I₃ ⊗ G (G the N × 4 stack of seed 004's C(n)), so the null space of Γ is that of G for
    each sensor axis; the words come from a sparse (row-echelon) basis of G's null space.

    Examples
    --------
    >>> import core
    >>> o = core.calibration_observability(core.level_headings(), [34000, 2000, 35000])
    >>> o.rank
    9
    >>> o.descriptions[0].split(":")[0]
    "K's third column and Bp cannot be told apart"
    """
    att = _attitudes(attitudes)
    if att.ndim != 2:
        raise ValueError(f"attitudes must have shape (N, 3) for one manoeuvre; got {att.shape}")
    rtol = _positive("rtol", rtol, "relative")
    be = _be(be)
    G = calibration_gamma(att, be, convention=convention)
    scale, s, Vt, rank = _scaled_svd(G, rtol)
    s12 = np.zeros(12)
    s12[:s.size] = s / s[0]
    null = Vt[rank:] / scale  # physical units
    # per-axis structure, for the words and for a sparse basis
    C = design_rows(att, be, convention=convention)
    cs, _, cVt, crank = _scaled_svd(C, rtol)
    words = []
    if crank < 4:
        basis = _rref(cVt[crank:]) / cs  # rows: per-axis null vectors, physical units
        words = [_describe(v) for v in basis]
    observable = np.ones(12, dtype=bool)
    if rank < 12:
        observable = np.linalg.norm(Vt[rank:], axis=0) < 1e-8
    cond = float(s[0] / s[-1]) if rank == 12 else float("inf")
    return CalibrationObservability(rank, s12, null, tuple(words), observable, cond)


def calibration_covariance(attitudes, be, *, noise_nt, angle_noise_rad=0.0, K=None,
                           convention="seed004", estimator="crlb"):
    """Covariance of the 12 coefficients: the Cramér–Rao bound, or that of the least-squares fit.

    Parameters
    ----------
    attitudes : array_like, shape (N, 3)
        ψ, θ, φ (rad).
    be : array_like, shape (3,)
        Geomagnetic field (nT).
    noise_nt : float
        Standard deviation of each reading's noise (nT), > 0, independent across axes and
        attitudes.
    angle_noise_rad : float
        Standard deviation of each recorded angle's error (rad), ≥ 0. Its effect is linearised:
        it adds ``J Σ_a Jᵀ`` to attitude n's 3 × 3 reading covariance, J = K ∂(A Be)/∂(ψ, θ, φ).
    K : array_like, shape (3, 3), optional
        Where J is evaluated (default the identity); irrelevant when ``angle_noise_rad = 0``.
    convention : str
        See :func:`attitude_matrix`.
    estimator : {"crlb", "lsq"}
        ``"crlb"``: the inverse Fisher information (Γᵀ Σ⁻¹ Γ)⁻¹ for Gaussian errors of these
        standard deviations. ``"lsq"``: the covariance of the unweighted least-squares estimate
        (what :func:`lsq_calibrate` and seed 004's filter with one σ² compute),
        (ΓᵀΓ)⁻¹ Γᵀ Σ Γ (ΓᵀΓ)⁻¹, equal to the CRLB when ``angle_noise_rad = 0``.

    Returns
    -------
    ndarray, shape (12, 12)
        In coefficient units² (order :data:`COEFFICIENTS`). Where the manoeuvre leaves a
        coefficient undetermined its row and column are +inf.

    Notes
    -----
    For non-Gaussian errors with these standard deviations (seed 004's bounded errors, modelled
    as uniform) the Cramér–Rao regularity conditions do not hold; the value is then the
    Gauss–Markov bound, the smallest covariance any *linear* unbiased estimator (least squares,
    seed 004's filter) can reach.
    """
    att = _attitudes(attitudes)
    if att.ndim != 2:
        raise ValueError(f"attitudes must have shape (N, 3) for one manoeuvre; got {att.shape}")
    be = _be(be)
    sb = _positive("noise_nt", noise_nt, "nT")
    sa = _positive("angle_noise_rad", angle_noise_rad, "rad", allow_zero=True)
    if estimator not in ("crlb", "lsq"):
        raise ValueError(f"estimator must be 'crlb' or 'lsq'; got {estimator!r}")
    Kmat = np.eye(3) if K is None else _K(K)
    if Kmat.shape != (3, 3):
        raise ValueError(f"K must have shape (3, 3); got {Kmat.shape}")
    factors = _convention(convention)
    N = att.shape[0]
    G = calibration_gamma(att, be, convention=convention).reshape(N, 3, 12)
    # per-attitude reading covariance Σ_n = σ_B² I + σ_a² J Jᵀ, J = K dA/dangle Be  (3 × 3)
    _, dA = _attitude(att, factors)
    J = np.einsum("ij,nkjl,l->nik", Kmat, dA, be)  # (N, 3 readings, 3 angles)
    S = sb ** 2 * np.eye(3) + sa ** 2 * J @ np.swapaxes(J, -1, -2)
    scale, s, Vt, rank = _scaled_svd(G.reshape(3 * N, 12), CAL_RANK_RTOL)
    # Work in the determined subspace (the first `rank` right singular vectors of the scaled Γ):
    # a pseudo-inverse of F itself would invert F's round-off eigenvalues (~eps · largest).
    Vr = Vt[:rank].T  # (12, r)
    Gr = (G / scale) @ Vr  # (N, 3, r)
    if estimator == "crlb":
        F = np.einsum("nki,nkl,nlj->ij", Gr, np.linalg.inv(S), Gr)
        cov_r = np.linalg.inv(F)
    else:
        Hinv = np.linalg.inv(np.einsum("nki,nkj->ij", Gr, Gr))
        cov_r = Hinv @ np.einsum("nki,nkl,nlj->ij", Gr, S, Gr) @ Hinv
    cov = Vr @ cov_r @ Vr.T
    cov = cov / np.outer(scale, scale)
    if rank < 12:
        bad = np.linalg.norm(Vt[rank:], axis=0) >= 1e-8
        cov[bad, :] = np.inf
        cov[:, bad] = np.inf
    return cov


def calibration_crlb(attitudes, be, *, noise_nt, angle_noise_rad=0.0, K=None,
                     convention="seed004"):
    """Cramér–Rao standard deviation of each of the 12 coefficients.

    Parameters are those of :func:`calibration_covariance`.

    Returns
    -------
    ndarray, shape (12,)
        In the order of :data:`COEFFICIENTS` (K dimensionless, Bp in nT); +inf for coefficients
        the manoeuvre does not determine.

    Examples
    --------
    >>> import numpy as np, core
    >>> s = core.calibration_crlb(core.level_headings(), [34000, 2000, 35000], noise_nt=100)
    >>> bool(np.isfinite(s[0])), bool(np.isinf(s[2])), bool(np.isinf(s[9]))
    (True, True, True)
    """
    cov = calibration_covariance(attitudes, be, noise_nt=noise_nt, angle_noise_rad=angle_noise_rad,
                                 K=K, convention=convention)
    return np.sqrt(np.diag(cov))


# --------------------------------------------------------------------------- estimators
@dataclass(frozen=True)
class LsqResult:
    """Batch least-squares calibration (:func:`lsq_calibrate`).

    Attributes
    ----------
    K : ndarray, shape (..., 3, 3)
        Induced-interference matrix (dimensionless).
    Bp : ndarray, shape (..., 3)
        Permanent-interference vector (nT).
    rank : int
        Rank of Γ (12 when the manoeuvre determines everything; otherwise K and Bp are the
        minimum-norm solution in column-scaled coordinates, one of many).
    residual_rms_nt : ndarray, shape (...)
        RMS of B − (K A Be + Bp) over all readings (nT).
    """

    K: np.ndarray
    Bp: np.ndarray
    rank: int
    residual_rms_nt: np.ndarray


def _min_attitudes(att):
    if att.shape[-2] < 4:
        raise ValueError(f"need at least 4 attitudes to determine the 12 coefficients (3 equations "
                         f"each); got {att.shape[-2]}")


def lsq_calibrate(B, attitudes, be, *, convention="seed004"):
    """Batch least-squares K and Bp from readings at known attitudes.

    Parameters
    ----------
    B : array_like, shape (..., N, 3)
        Readings (nT).
    attitudes : array_like, shape (..., N, 3)
        ψ, θ, φ (rad), N ≥ 4; the leading axes of B and attitudes must match.
    be : array_like, shape (3,)
        Geomagnetic field (nT).
    convention : str
        See :func:`attitude_matrix`.

    Returns
    -------
    LsqResult

    Examples
    --------
    >>> import numpy as np, core
    >>> att = core.heading_manoeuvre(roll_deg=10, pitch_deg=5, n_attitudes=8)
    >>> B = core.ship_field(np.eye(3), [100, 200, 300], att, [34000, 2000, 35000])
    >>> np.round(core.lsq_calibrate(B, att, [34000, 2000, 35000]).Bp, 6).tolist()
    [100.0, 200.0, 300.0]
    """
    att = _attitudes(attitudes)
    _min_attitudes(att)
    B = _readings(B, att)
    C = design_rows(att, be, convention=convention)  # (..., N, 4)
    lead = np.broadcast_shapes(C.shape[:-2], B.shape[:-2])
    C = np.broadcast_to(C, lead + C.shape[-2:])
    B = np.broadcast_to(B, lead + B.shape[-2:])
    scale = np.linalg.norm(C, axis=-2, keepdims=True)  # (..., 1, 4)
    U, s, Vt = np.linalg.svd(C / scale, full_matrices=False)
    keep = s > CAL_RANK_RTOL * s[..., :1]
    sinv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    X = np.swapaxes(Vt, -1, -2) @ (sinv[..., :, None] * (np.swapaxes(U, -1, -2) @ B))  # (..., 4, 3)
    X = X / np.swapaxes(scale, -1, -2)
    res = B - C @ X
    rank = 3 * int(np.min(np.sum(keep, axis=-1)))
    return LsqResult(np.swapaxes(X[..., :3, :], -1, -2), X[..., 3, :], rank,
                     np.sqrt(np.mean(res ** 2, axis=(-2, -1))))


@dataclass(frozen=True)
class KalmanResult:
    """Seed 004's Kalman filter run (:func:`kalman_calibrate`).

    Attributes
    ----------
    history : ndarray, shape (..., M + 1, 4, 3)
        Seed 004's state x(n) = [K Bp]ᵀ for n = 0…M (x(0) the initial value).
    P_diag : ndarray, shape (..., M + 1, 4)
        Diagonal of P(n) (K entries dimensionless², Bp in nT²), shared by the three axes.
    """

    history: np.ndarray
    P_diag: np.ndarray

    @property
    def K_history(self):
        """ndarray, shape (..., M + 1, 3, 3): K after each iteration (dimensionless)."""
        return np.swapaxes(self.history[..., :3, :], -1, -2)

    @property
    def Bp_history(self):
        """ndarray, shape (..., M + 1, 3): Bp after each iteration (nT)."""
        return self.history[..., 3, :]

    @property
    def K(self):
        """ndarray, shape (..., 3, 3): the final K."""
        return self.K_history[..., -1, :, :]

    @property
    def Bp(self):
        """ndarray, shape (..., 3): the final Bp (nT)."""
        return self.Bp_history[..., -1, :]

    @property
    def coefficients(self):
        """ndarray, shape (..., M + 1, 12): the history in the order of :data:`COEFFICIENTS`."""
        lead = self.history.shape[:-2]
        return np.concatenate([self.K_history.reshape(lead + (9,)), self.Bp_history], axis=-1)


#: Default prior of :func:`kalman_calibrate`: x(0) = 0 as seed 004 suggests ("with little prior
#: information take x(0) = 0"), with standard deviations of 1 for each K entry and 3000 nT for
#: each Bp entry (the size of the values seed 004 reports) in P(0).
DEFAULT_P0_DIAG = (1.0, 1.0, 1.0, 3000.0 ** 2)


def kalman_calibrate(B, attitudes, be, *, sigma_nt, iterations=None, x0=None, P0=None, Q=None,
                     convention="seed004"):
    """Seed 004's linear Kalman filter for the state x = [K Bp]ᵀ (4 × 3).

    Parameters
    ----------
    B : array_like, shape (..., N, 3)
        Readings (nT).
    attitudes : array_like, shape (..., N, 3)
        ψ, θ, φ (rad).
    be : array_like, shape (3,)
        Geomagnetic field (nT).
    sigma_nt : float
        Observation noise standard deviation σ (nT), > 0 (seed 004's σ²).
    iterations : int, optional
        Number of filter steps M ≥ 1; the N readings are reused cyclically when M > N (seed
        004's "extension" of its 12 readings). Default N (one pass).
    x0 : array_like, shape (4, 3), optional
        Initial state (seed 004: zero, the default).
    P0 : array_like, shape (4,) or (4, 4), optional
        Initial P(0) (diagonal or full; K part dimensionless², Bp part nT²); default
        :data:`DEFAULT_P0_DIAG`.
    Q : array_like, shape (4,) or (4, 4) or float, optional
        Random-walk process noise per step (same units as P); default 0 (constant coefficients).
    convention : str
        See :func:`attitude_matrix`.

    Returns
    -------
    KalmanResult

    Notes
    -----
    Seed 004's steps (§2.1) for n = 1…M with C(n) = [Beᵀ Aᵀ(n), 1], y(n) = B(n)ᵀ:
    R = P(n−1) + Q; m = R Cᵀ / (C R Cᵀ + σ²); x(n) = (E − m C) x(n−1) + m y(n);
    P(n) = (E − m C) R. (The printed gain lacks the inverse of C R Cᵀ + σ², a scalar here.)
    P is updated in the Joseph form (E − m C) R (E − m C)ᵀ + σ² m mᵀ, algebraically the same and
    more robust in float64. Still, a covariance-form filter subtracts nearly equal numbers when
    P(0) exceeds the final P by more than ~1e12 (e.g. P(0) = 1e12 for every entry): the
    estimate then reaches the least-squares value only slowly. Scale P(0) to the coefficients
    (K ~ 1, Bp ~ |Be|) rather than making it uniformly enormous.
    """
    att = _attitudes(attitudes)
    B = _readings(B, att)
    be = _be(be)
    sigma2 = _positive("sigma_nt", sigma_nt, "nT") ** 2
    N = att.shape[-2]
    M = N if iterations is None else iterations
    if isinstance(M, bool) or not isinstance(M, (int, np.integer)) or M < 1:
        raise ValueError(f"iterations must be an integer ≥ 1; got {iterations!r}")
    P = _square4("P0", DEFAULT_P0_DIAG if P0 is None else P0, allow_zero=False)
    Qm = _square4("Q", 0.0 if Q is None else Q, allow_zero=True)
    x = np.zeros((4, 3)) if x0 is None else _array("x0", x0, "shape (4, 3): [K Bp]ᵀ")
    if x.shape != (4, 3):
        raise ValueError(f"x0 must have shape (4, 3) ([K Bp]ᵀ); got {x.shape}")
    C = design_rows(att, be, convention=convention)  # (..., N, 4)
    lead = np.broadcast_shapes(C.shape[:-2], B.shape[:-2])
    C = np.broadcast_to(C, lead + C.shape[-2:])
    B = np.broadcast_to(B, lead + B.shape[-2:])
    x = np.broadcast_to(x, lead + (4, 3)).copy()
    P = np.broadcast_to(P, lead + (4, 4)).copy()
    hist = np.empty(lead + (M + 1, 4, 3))
    pdiag = np.empty(lead + (M + 1, 4))
    hist[..., 0, :, :] = x
    pdiag[..., 0, :] = np.diagonal(P, axis1=-2, axis2=-1)
    E = np.eye(4)
    for n in range(1, M + 1):
        c = C[..., (n - 1) % N, :]  # (..., 4)
        y = B[..., (n - 1) % N, :]  # (..., 3)
        R = P + Qm
        Rc = (R @ c[..., :, None])[..., 0]  # R Cᵀ (..., 4)
        m = Rc / ((c * Rc).sum(axis=-1) + sigma2)[..., None]  # gain (..., 4)
        innov = y - (c[..., None, :] @ x)[..., 0, :]  # y − C x (..., 3)
        x = x + m[..., :, None] * innov[..., None, :]
        IKC = E - m[..., :, None] * c[..., None, :]
        P = IKC @ R @ np.swapaxes(IKC, -1, -2) + sigma2 * m[..., :, None] * m[..., None, :]
        P = 0.5 * (P + np.swapaxes(P, -1, -2))
        hist[..., n, :, :] = x
        pdiag[..., n, :] = np.diagonal(P, axis1=-2, axis2=-1)
    return KalmanResult(hist, pdiag)


def convergence_iteration(history, tol):
    """First iteration after which every coefficient stays within ``tol`` of its final value.

    Parameters
    ----------
    history : array_like, shape (..., M + 1, 12)
        Estimates after each iteration (e.g. :attr:`KalmanResult.coefficients`).
    tol : array_like, shape (12,) or float
        Tolerance per coefficient (coefficient units), > 0, e.g. the CRLB standard deviations;
        +inf ignores a coefficient (an undetermined one's CRLB).

    Returns
    -------
    ndarray of int, shape (...)
        0 if x(0) is already within tolerance, M if only the last estimate is.
    """
    h = _array("history", history, "shape (..., M + 1, 12)")
    try:
        t = np.asarray(tol, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be numbers > 0 (coefficient units); got {tol!r}") from None
    if h.ndim < 2 or h.shape[-1] != 12:
        raise ValueError(f"history must have shape (..., M + 1, 12); got {h.shape}")
    if not (t > 0).all():  # also refuses NaN
        raise ValueError("tol must be > 0 (coefficient units; +inf ignores a coefficient)")
    ok = np.all(np.abs(h - h[..., -1:, :]) <= t, axis=-1)  # (..., M + 1)
    # the last iteration that is not within tolerance, plus one
    bad_rev = np.argmax(~ok[..., ::-1], axis=-1)  # position from the end of the last bad one
    any_bad = (~ok).any(axis=-1)
    return np.where(any_bad, ok.shape[-1] - bad_rev, 0)


def _square4(name, value, allow_zero):
    arr = _array(name, value, "a number, 4 diagonal entries or a 4 × 4 matrix")
    if arr.ndim == 0:
        arr = np.full(4, float(arr))
    if arr.shape == (4,):
        if (arr < 0).any() or (not allow_zero and (arr <= 0).any()):
            raise ValueError(f"{name}'s diagonal must be {'≥' if allow_zero else '>'} 0; got {arr}")
        return np.diag(arr)
    if arr.shape != (4, 4) or not np.allclose(arr, arr.T):
        raise ValueError(f"{name} must be a number, 4 diagonal entries or a symmetric 4 × 4 "
                         f"matrix; got shape {arr.shape}")
    return arr


# --------------------------------------------------------------------------- geomagnetic solution
def geomagnetic_solution(B, attitudes, K, Bp, *, convention="seed004"):
    """The geomagnetic field recovered from the readings, Be = (K A)⁻¹ (B − Bp) (seed 004, eq. (4)).

    Parameters
    ----------
    B : array_like, shape (..., N, 3)
        Readings (nT).
    attitudes : array_like, shape (..., N, 3)
        ψ, θ, φ (rad).
    K : array_like, shape (3, 3)
        Induced-interference matrix (dimensionless), invertible.
    Bp : array_like, shape (3,)
        Permanent-interference vector (nT).
    convention : str
        See :func:`attitude_matrix`.

    Returns
    -------
    ndarray, shape (..., N, 3)
        Be in the earth frame (nT), one estimate per attitude.
    """
    att = _attitudes(attitudes)
    B = _readings(B, att)
    K, Bp = _K(K), _vector3("Bp", Bp, "nT")
    if K.shape != (3, 3):
        raise ValueError(f"K must have shape (3, 3); got {K.shape}")
    if np.linalg.cond(K) > 1e12:
        raise ValueError("K must be invertible (its condition number exceeds 1e12)")
    A = _attitude(att, _convention(convention))[0]
    # (K A)⁻¹ = Aᵀ K⁻¹ (A orthogonal)
    return np.einsum("...ji,...j->...i", A, (B - Bp) @ np.linalg.inv(K).T)


@dataclass(frozen=True)
class GeomagneticError:
    """Error of a geomagnetic solution (:func:`geomagnetic_error`).

    Attributes
    ----------
    rms_nt : float
        RMS over all components and attitudes of (Be_hat − Be) (nT).
    vector_rms_nt : float
        RMS over attitudes of |Be_hat − Be| (nT) (= √3 · rms_nt when the components share it).
    max_rel : float
        Largest |component error| over |Be| (seed 004's "largest relative error", 1.9 %).
    """

    rms_nt: float
    vector_rms_nt: float
    max_rel: float


def geomagnetic_error(be_hat, be):
    """RMS and largest relative error of a geomagnetic solution.

    Parameters
    ----------
    be_hat : array_like, shape (N, 3)
        Recovered Be (nT), e.g. from :func:`geomagnetic_solution`.
    be : array_like, shape (3,)
        True Be (nT).

    Returns
    -------
    GeomagneticError
    """
    be = _be(be)
    est = _array("be_hat", be_hat, "shape (N, 3) in nT")
    if est.shape[-1:] != (3,):
        raise ValueError(f"be_hat must have shape (N, 3) in nT; got {est.shape}")
    err = est - be
    return GeomagneticError(float(np.sqrt(np.mean(err ** 2))),
                            float(np.sqrt(np.mean(np.sum(err ** 2, axis=-1)))),
                            float(np.max(np.abs(err)) / np.linalg.norm(be)))


# --------------------------------------------------------------------------- manoeuvres
def _angles_deg(name, value):
    arr = _array(name, value, "degrees")
    return np.atleast_1d(arr)


def level_headings(headings_deg=(0.0, 90.0, 180.0, 270.0)):
    """The classic four-heading manoeuvre: level (roll = pitch = 0) on each heading.

    Parameters
    ----------
    headings_deg : sequence of float
        Headings (deg, clockwise from north); default N, E, S, W.

    Returns
    -------
    ndarray, shape (H, 3)
        Attitudes [ψ, 0, 0] (rad).
    """
    h = _angles_deg("headings_deg", headings_deg)
    if h.ndim != 1 or h.size < 1:
        raise ValueError("headings_deg must be a non-empty sequence of headings in degrees")
    return np.stack([np.deg2rad(h), np.zeros_like(h), np.zeros_like(h)], axis=-1)


def heading_manoeuvre(headings_deg=(0.0, 90.0, 180.0, 270.0), *, roll_deg=10.0, pitch_deg=5.0,
                      n_attitudes=12):
    """Headings sailed in turn while the ship rolls and pitches.

    Attitude n (n = 0…N−1) is on heading ``headings_deg[n mod H]`` with roll
    ``roll_deg · cos(2π n / N)`` and pitch ``pitch_deg · sin(2π n / N)``: roll and pitch trace one
    ellipse of the given amplitudes over the manoeuvre, so they vary between attitudes (a
    constant heel, like level headings, leaves K's third column and Bp confounded).

    Parameters
    ----------
    headings_deg : sequence of float
        Headings (deg).
    roll_deg, pitch_deg : float
        Amplitudes (deg), |·| ≤ 90.
    n_attitudes : int
        N ≥ 1.

    Returns
    -------
    ndarray, shape (N, 3)
        Attitudes [ψ, θ, φ] (rad).

    Examples
    --------
    >>> import core
    >>> core.heading_manoeuvre(n_attitudes=12).shape
    (12, 3)
    """
    h = _angles_deg("headings_deg", headings_deg)
    if h.ndim != 1 or h.size < 1:
        raise ValueError("headings_deg must be a non-empty sequence of headings in degrees")
    for name, v in (("roll_deg", roll_deg), ("pitch_deg", pitch_deg)):
        a = _array(name, v, "degrees")
        if a.shape != () or abs(float(a)) > 90:
            raise ValueError(f"{name} must be one amplitude in degrees with |{name}| ≤ 90; got {v!r}")
    if isinstance(n_attitudes, bool) or not isinstance(n_attitudes, (int, np.integer)) or n_attitudes < 1:
        raise ValueError(f"n_attitudes must be an integer ≥ 1; got {n_attitudes!r}")
    n = np.arange(n_attitudes)
    t = 2.0 * np.pi * n / n_attitudes
    return np.stack([np.deg2rad(h[n % h.size]), np.deg2rad(float(roll_deg)) * np.cos(t),
                     np.deg2rad(float(pitch_deg)) * np.sin(t)], axis=-1)


def random_attitudes(n_attitudes, rng, *, heading_deg=(0.0, 360.0), roll_deg=(-20.0, 20.0),
                     pitch_deg=(-15.0, 15.0), size=()):
    """Attitudes drawn uniformly in ranges, as in seed 004's simulation (defaults are its ranges).

    Parameters
    ----------
    n_attitudes : int
        N ≥ 1.
    rng : numpy.random.Generator
    heading_deg, roll_deg, pitch_deg : (float, float)
        Ranges (deg).
    size : tuple of int
        Leading shape (independent manoeuvres).

    Returns
    -------
    ndarray, shape size + (N, 3)
        ψ, θ, φ (rad); headings above 180° are returned as ψ − 360° so that |ψ| ≤ π.
    """
    if isinstance(n_attitudes, bool) or not isinstance(n_attitudes, (int, np.integer)) or n_attitudes < 1:
        raise ValueError(f"n_attitudes must be an integer ≥ 1; got {n_attitudes!r}")
    cols = []
    for name, r in (("heading_deg", heading_deg), ("roll_deg", roll_deg), ("pitch_deg", pitch_deg)):
        lo, hi = _array(name, r, "(low, high) degrees")
        if not lo <= hi or max(abs(lo), abs(hi)) > 360:
            raise ValueError(f"{name} must be (low, high) degrees with low ≤ high, |·| ≤ 360; got {r!r}")
        cols.append(np.deg2rad(rng.uniform(lo, hi, size=tuple(size) + (n_attitudes,))))
    cols[0] = np.angle(np.exp(1j * cols[0]))  # wrap to (−π, π]
    return np.stack(cols, axis=-1)


def simulate_ship_data(K, Bp, attitudes, be, rng, *, noise_nt=0.0, angle_noise_deg=0.0,
                       distribution="uniform", convention="seed004"):
    """Readings at the true attitudes plus errors, and the attitudes as recorded (with errors).

    Parameters
    ----------
    K, Bp, attitudes, be, convention
        As for :func:`ship_field`; attitudes (..., N, 3) are the true ones.
    rng : numpy.random.Generator
    noise_nt : float
        Error size on each reading (nT), ≥ 0.
    angle_noise_deg : float
        Error size on each recorded angle (deg), ≥ 0.
    distribution : {"uniform", "gaussian"}
        ``"uniform"``: errors uniform in ±size (seed 004: "random errors of at most 100 nT /
        0.05°"; a bound, so uniform; standard deviation size/√3). ``"gaussian"``: standard
        deviation = size.

    Returns
    -------
    B : ndarray, shape (..., N, 3)
        Readings (nT).
    recorded : ndarray, shape (..., N, 3)
        Recorded attitudes (rad).
    """
    att = _attitudes(attitudes)
    sb = _positive("noise_nt", noise_nt, "nT", allow_zero=True)
    sa = np.deg2rad(_positive("angle_noise_deg", angle_noise_deg, "deg", allow_zero=True))
    if distribution == "uniform":
        draw = lambda s: rng.uniform(-s, s, size=att.shape)
    elif distribution == "gaussian":
        draw = lambda s: rng.normal(0.0, s, size=att.shape) if s > 0 else np.zeros(att.shape)
    else:
        raise ValueError(f"distribution must be 'uniform' or 'gaussian'; got {distribution!r}")
    B = ship_field(K, Bp, att, be, convention=convention) + draw(sb)
    return B, att + draw(sa)


# --------------------------------------------------------------------------- data
def parse_attitude_csv(text):
    """Readings and attitudes from CSV text with columns B1, B2, B3 (nT), psi, theta, phi (rad).

    Parameters
    ----------
    text : str or bytes
        The CSV (header row first; extra columns ignored; a UTF-8 BOM is accepted).

    Returns
    -------
    B : ndarray, shape (N, 3)
        Readings (nT).
    attitudes : ndarray, shape (N, 3)
        ψ, θ, φ (rad).

    Raises
    ------
    ValueError
        Missing columns, a non-numeric or non-finite cell, an |angle| > 2π (degrees given by
        mistake), or fewer than 4 attitudes (the 12 coefficients need at least 4 × 3 readings).
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise ValueError("the CSV must be UTF-8 text") from None
    text = text.lstrip("\ufeff")
    rows = [r for r in csv.reader(io.StringIO(text)) if any(c.strip() for c in r)]
    if not rows:
        raise ValueError(f"the CSV is empty; expected a header row with columns {', '.join(CSV_COLUMNS)}")
    header = [c.strip() for c in rows[0]]
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"the CSV lacks column(s) {', '.join(missing)}; it needs {', '.join(CSV_COLUMNS)} "
                         f"(B in nT, angles in rad); found {', '.join(header) or 'none'}")
    idx = [header.index(c) for c in CSV_COLUMNS]
    data = np.empty((len(rows) - 1, 6))
    for r, row in enumerate(rows[1:], start=2):
        for j, (c, col) in enumerate(zip(idx, CSV_COLUMNS)):
            cell = row[c].strip() if c < len(row) else ""
            try:
                v = float(cell.replace("−", "-"))
            except ValueError:
                raise ValueError(f"line {r}, column {col}: {cell!r} is not a number") from None
            if not np.isfinite(v):
                raise ValueError(f"line {r}, column {col}: {cell!r} is not a finite number")
            data[r - 2, j] = v
    big = np.abs(data[:, 3:]) > ANGLE_LIMIT
    if big.any():
        r, j = map(int, np.argwhere(big)[0])
        raise ValueError(f"line {r + 2}, column {CSV_COLUMNS[3 + j]}: {data[r, 3 + j]:g} exceeds 2π; "
                         "angles must be in radians (degrees given by mistake? multiply by π/180)")
    if data.shape[0] < 4:
        raise ValueError(f"the CSV has {data.shape[0]} attitude(s); the 12 coefficients need at "
                         "least 4 (3 readings each)")
    return data[:, :3], data[:, 3:]


def read_attitude_csv(path):
    """:func:`parse_attitude_csv` of a file (path); ValueError if it cannot be read."""
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from None
    return parse_attitude_csv(raw)


def seed004_table1_path():
    """Path of ``data/seed004_table1.csv`` (seed 004's Table 1).

    Looked up next to the package (a clone or an editable install: ``<repo>/data``), then in
    ``./data`` (the Docker image's working directory holds the repository).
    """
    for base in (Path(__file__).resolve().parents[1], Path.cwd()):
        p = base / "data" / "seed004_table1.csv"
        if p.is_file():
            return p
    raise ValueError("data/seed004_table1.csv not found next to the package or in ./data")


def seed004_table1():
    """Seed 004's Table 1: readings (12, 3) in nT and attitudes (12, 3) in rad."""
    return read_attitude_csv(seed004_table1_path())


# --------------------------------------------------------------------------- CLI
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


if __name__ == "__main__":
    sys.exit(main())
