"""What a manoeuvre determines: the rank of Γ, its unobservable directions and the Cramér–Rao
bound of the 12 coefficients.

Γ of the 12 coefficients is ``I₃ ⊗ G`` (G the N × 4 stack of seed 004's rows C(n), the three
sensor axes sharing it), so everything here is computed from G's thin QR factor R (4 × 4) and
from 12 × 12 sums over the attitudes: time and memory linear in N, never an N × N array.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import CHUNK, _attitude, _convention, design_rows
from ..model.validation import positive
from .validation import _K, _attitudes, checked_angle_noise, checked_be, checked_noise

#: Γ (columns scaled to unit norm) has rank r when r singular values exceed CAL_RANK_RTOL times
#: the largest. Exactly confounded coefficients (level headings) give ≤ 1e-15 (round-off); a
#: roll of amplitude 0.01° (0.01°, 0, −0.01°, 0 on the four headings) already gives 2.5e-6
#: (tests/test_calibration.py), so 1e-9 separates "not determined at all" from "determined,
#: perhaps poorly" with ≥ 3 decades either side. How poorly is the CRLB's job, not the rank's.
CAL_RANK_RTOL = 1e-9

#: Where coefficient (sensor axis i, design column j) sits among the 12 (order of COEFFICIENTS):
#: j = 0, 1, 2 → k_i(j+1) at 3i + j; j = 3 → Bp_i at 9 + i.  Shape (3 axes, 4 columns).
_INDEX = np.array([[3 * i, 3 * i + 1, 3 * i + 2, 9 + i] for i in range(3)])


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


def _thin_svd(C, rtol):
    """Column scales, singular values and right singular vectors of the column-scaled C (N × 4),
    from its thin QR factor: O(N) time and memory (R is 4 × 4; the SVD of R has C's singular
    values and right vectors to round-off, as Householder QR is backward stable).

    Returns scale (4,), s (4,) descending (zero-padded when N < 4), Vt (4, 4), rank (int)."""
    scale = np.linalg.norm(C, axis=-2)
    scale = np.where(scale > 0, scale, 1.0)
    R = np.linalg.qr(C / scale, mode="r")  # (min(N, 4), 4)
    _, s_r, Vt = np.linalg.svd(R, full_matrices=True)
    s = np.zeros(4)
    s[:s_r.size] = s_r
    rank = int(np.sum(s > rtol * s[0])) if s[0] > 0 else 0
    return scale, s, Vt, rank


def _per_axis(v4):
    """The 12-vectors (rows) e_i ⊗ v of 4-vectors v (rows of v4), axis-major: shape (3 · m, 12)."""
    out = np.zeros((3, v4.shape[0], 12))
    for i in range(3):
        out[i][:, _INDEX[i]] = v4
    return out.reshape(3 * v4.shape[0], 12)


def _scale12(scale4):
    s = np.empty(12)
    s[_INDEX] = scale4  # column (i, j) of Γ has the norm of G's column j
    return s


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
    attitudes, be, convention
        As for :func:`ship_field`, for one manoeuvre: attitudes (N, 3).
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
    att = _attitudes(attitudes, one="manoeuvre")
    rtol = positive("rtol", rtol, "relative")
    C = design_rows(att, checked_be(be), convention=convention)  # (N, 4)
    scale, s, Vt, crank = _thin_svd(C, rtol)
    rank = 3 * crank
    # Γ's singular values are G's, each three times (one per sensor axis)
    s12 = np.repeat(s / s[0], 3)
    null = _per_axis(Vt[crank:]) / _scale12(scale)  # physical units
    words = []
    if crank < 4:
        basis = _rref(Vt[crank:]) / scale  # rows: per-axis null vectors, physical units
        words = [_describe(v) for v in basis]
    observable = _determined(Vt, crank)
    cond = float(s[0] / s[-1]) if rank == 12 else float("inf")
    return CalibrationObservability(rank, s12, null, tuple(words), observable, cond)


def _determined(Vt, crank):
    """Which of the 12 coefficients are orthogonal to every null direction, shape (12,) bool."""
    observable = np.ones(12, dtype=bool)
    if crank < 4:
        observable[_INDEX] = np.linalg.norm(Vt[crank:], axis=0) < 1e-8
    return observable


def _gram12(g, W):
    """Σ_n Γ_nᵀ W_n Γ_n for the rows Γ_n = I₃ ⊗ g_n of one block: g (n, 4), W (n, 3, 3) → (12, 12).

    Entry ((i, j), (k, l)) is Σ_n W_n[i, k] g_n[j] g_n[l]."""
    gg = g[:, :, None] * g[:, None, :]  # (n, 4, 4)
    T = np.tensordot(W, gg, axes=(0, 0))  # (3, 3, 4, 4): [i, k, j, l]
    F = np.zeros((12, 12))
    F[_INDEX[:, :, None, None], _INDEX[None, None, :, :]] = T.transpose(0, 2, 1, 3)
    return F


def calibration_covariance(attitudes, be, *, noise_nt, angle_noise_rad=0.0, K=None,
                           convention="seed004", estimator="crlb"):
    """Covariance of the 12 coefficients: the Cramér–Rao bound, or that of the least-squares fit.

    Parameters
    ----------
    attitudes, be, convention
        As for :func:`ship_field`, for one manoeuvre: attitudes (N, 3).
    noise_nt : float
        Standard deviation of each reading's noise (nT), > 0, independent across axes and
        attitudes.
    angle_noise_rad : float
        Standard deviation of each recorded angle's error (rad), ≥ 0. Its effect is linearised:
        it adds ``J Σ_a Jᵀ`` to attitude n's 3 × 3 reading covariance, J = K ∂(A Be)/∂(ψ, θ, φ).
    K : array_like, shape (3, 3), optional
        Where J is evaluated (default the identity); irrelevant when ``angle_noise_rad = 0``.
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
    att = _attitudes(attitudes, one="manoeuvre")
    be = checked_be(be)
    sb = checked_noise("noise_nt", noise_nt)
    sa = checked_angle_noise("angle_noise_rad", angle_noise_rad)
    if estimator not in ("crlb", "lsq"):
        raise ValueError(f"estimator must be 'crlb' or 'lsq'; got {estimator!r}")
    Kmat = np.eye(3) if K is None else _K(K)
    if Kmat.shape != (3, 3):
        raise ValueError(f"K must have shape (3, 3); got {Kmat.shape}")
    factors = _convention(convention)
    N = att.shape[0]
    C = design_rows(att, be, convention=convention)  # (N, 4)
    scale, _, Vt, crank = _thin_svd(C, CAL_RANK_RTOL)
    # Work in the determined subspace (the right singular vectors of the scaled Γ above the
    # rank tolerance): a pseudo-inverse of F itself would invert F's round-off eigenvalues
    # (~eps · largest).
    Vr = _per_axis(Vt[:crank]).T  # (12, r)
    # 1. Sums over the attitudes, block by block: H = Σ Γ_sᵀ Γ_s and Σ Γ_sᵀ W Γ_s with W = Σ_n⁻¹
    #    (CRLB) or Σ_n (least squares), Σ_n = σ_B² I + σ_a² J Jᵀ, J = K dA/dangle Be (3 × 3).
    H = np.zeros((12, 12))
    F = np.zeros((12, 12))
    for a in range(0, N, CHUNK):
        g = C[a:a + CHUNK] / scale  # (n, 4)
        S = np.broadcast_to(sb ** 2 * np.eye(3), (g.shape[0], 3, 3))
        if sa > 0:
            _, dA = _attitude(att[a:a + CHUNK], factors)
            J = np.einsum("ij,nkjl,l->nik", Kmat, dA, be)  # (n, 3 readings, 3 angles)
            S = S + sa ** 2 * J @ np.swapaxes(J, -1, -2)
        F += _gram12(g, np.linalg.inv(S) if estimator == "crlb" else S)
        if estimator == "lsq":
            H += _gram12(g, np.broadcast_to(np.eye(3), S.shape))
    # 2. The covariance in the determined subspace, back to physical units.
    if estimator == "crlb":
        cov_r = np.linalg.inv(Vr.T @ F @ Vr)
    else:
        Hinv = np.linalg.inv(Vr.T @ H @ Vr)
        cov_r = Hinv @ (Vr.T @ F @ Vr) @ Hinv
    cov = Vr @ cov_r @ Vr.T
    s12 = _scale12(scale)
    cov = cov / np.outer(s12, s12)
    bad = ~_determined(Vt, crank)
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

