"""The geomagnetic field recovered from the readings with a calibration, and its error
(seed 004, eq. (4)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import CHUNK, _attitude, _convention
from .validation import _K, _array, _attitudes, _readings, _vector3, checked_be


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
    factors = _convention(convention)
    # (K A)⁻¹ = Aᵀ K⁻¹ (A orthogonal); in blocks of CHUNK attitudes (A is 3 × 3 per attitude)
    lead = np.broadcast_shapes(att.shape[:-1], B.shape[:-1])
    att = np.broadcast_to(att, lead + (3,)).reshape(-1, 3)
    u = ((B - Bp) @ np.linalg.inv(K).T)
    u = np.broadcast_to(u, lead + (3,)).reshape(-1, 3)
    out = np.empty(u.shape)
    for a in range(0, u.shape[0], CHUNK):
        A = _attitude(att[a:a + CHUNK], factors, derivative=False)[0]
        out[a:a + CHUNK] = np.einsum("nji,nj->ni", A, u[a:a + CHUNK])
    return out.reshape(lead + (3,))


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
    be = checked_be(be)
    est = _array("be_hat", be_hat, "shape (N, 3) in nT")
    if est.shape[-1:] != (3,):
        raise ValueError(f"be_hat must have shape (N, 3) in nT; got {est.shape}")
    err = est - be
    return GeomagneticError(float(np.sqrt(np.mean(err ** 2))),
                            float(np.sqrt(np.mean(np.sum(err ** 2, axis=-1)))),
                            float(np.max(np.abs(err)) / np.linalg.norm(be)))

