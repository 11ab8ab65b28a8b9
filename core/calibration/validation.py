"""Checks at the boundary of the calibration functions: each returns the value as a float array
(or float) or raises ValueError saying what was wrong and what is accepted.

Nothing here knows the model; the private kernels elsewhere in the package assume checked input.
"""

from __future__ import annotations

import numpy as np

from ..model.validation import positive

#: Largest |angle| accepted (rad). A heading of 90 means degrees were given by mistake.
ANGLE_LIMIT = 2.0 * np.pi
#: Accepted reading noise σ (nT): from 1 fT (below any magnetometer's) to 1 mT (the field
#: itself is ~50 000 nT); outside, σ² under- or overflows the sums and means nothing anyway.
NOISE_RANGE_NT = (1e-6, 1e6)
#: Largest angle-error σ accepted (rad, ≈ 11.5°): angle errors enter linearised, which is no
#: description of errors larger than this.
ANGLE_NOISE_MAX_RAD = 0.2
#: Accepted magnitude of Be (nT): the geomagnetic field is 22 000–67 000 nT; a coil-made field
#: in a lab may be smaller or larger, but not below 1 nT nor at 1e7 nT (10 mT) and above.
BE_RANGE_NT = (1.0, 1e7)


def _array(name, value, what):
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array ({what}): {exc}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite ({what}); NaN and inf are not accepted")
    return arr


def _attitudes(value, name="attitudes", one=None):
    """Checked attitudes (..., N, 3); ``one`` ("manoeuvre", "log"): exactly one, (N, 3)."""
    arr = _array(name, value, "shape (..., N, 3): heading ψ, roll θ, pitch φ in rad")
    if arr.ndim < 2 or arr.shape[-1] != 3 or arr.shape[-2] < 1:
        raise ValueError(f"{name} must have shape (..., N, 3) with N ≥ 1 rows of [ψ, θ, φ] in rad; "
                         f"got shape {arr.shape}")
    big = np.abs(arr) > ANGLE_LIMIT
    if big.any():
        raise ValueError(f"{name} must be in radians with |angle| ≤ 2π; got {arr[big].flat[0]:g} "
                         "(degrees given by mistake? multiply by π/180)")
    if one is not None and arr.ndim != 2:
        raise ValueError(f"{name} must have shape (N, 3) for one {one}; got {arr.shape}")
    return arr


def _vector3(name, value, unit):
    arr = _array(name, value, f"3 components in {unit}")
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a vector of 3 components in {unit}; got shape {arr.shape}")
    return arr


def checked_be(value):
    be = _vector3("be", value, "nT")
    norm = np.sqrt(np.sum(be ** 2)) if np.abs(be).max() < BE_RANGE_NT[1] else np.inf
    if not norm > 0:
        raise ValueError("be (the geomagnetic field, nT) must not be zero")
    if not BE_RANGE_NT[0] <= norm < BE_RANGE_NT[1]:
        raise ValueError(f"be (the geomagnetic field north, east, down) must have a magnitude from "
                         f"{BE_RANGE_NT[0]:g} nT to below {BE_RANGE_NT[1]:g} nT (the earth's is 22 000–67 000 "
                         f"nT); got |be| = {norm:g} nT")
    return be


def checked_noise(name, value):
    """A reading-noise σ in :data:`NOISE_RANGE_NT` (nT)."""
    v = positive(name, value, "nT")
    lo, hi = NOISE_RANGE_NT
    if not lo <= v <= hi:
        raise ValueError(f"{name} must be from {lo:g} to {hi:g} nT; got {value!r}")
    return v


def checked_angle_noise(name, value, unit="rad"):
    """An angle-error σ ≥ 0, at most :data:`ANGLE_NOISE_MAX_RAD` (given in ``unit``)."""
    v = positive(name, value, unit, zero=True)
    hi = ANGLE_NOISE_MAX_RAD if unit == "rad" else float(np.rad2deg(ANGLE_NOISE_MAX_RAD))
    if v > hi:
        raise ValueError(f"{name} must be from 0 to {hi:.3g} {unit} (angle errors are linearised); "
                         f"got {value!r}")
    return v


def _K(value):
    K = _array("K", value, "3 × 3, dimensionless")
    if K.shape[-2:] != (3, 3):
        raise ValueError(f"K must have shape (..., 3, 3) (dimensionless); got shape {K.shape}")
    return K


def _readings(B, attitudes):
    B = _array("B", B, "shape (..., N, 3) in nT")
    if B.shape[-1:] != (3,) or B.ndim < 2 or B.shape[-2] != attitudes.shape[-2]:
        raise ValueError(f"B must have shape (..., N, 3) in nT with one row per attitude "
                         f"(N = {attitudes.shape[-2]}); got shape {B.shape}")
    return B


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


def _min_attitudes(att):
    if att.shape[-2] < 4:
        raise ValueError(f"need at least 4 attitudes to determine the 12 coefficients (3 equations "
                         f"each); got {att.shape[-2]}")
