"""The loss of a station (spec §13): the CRLB when any one station fails, from the per-station
Fisher information computed once.

With independent stations F = Σ_s F_s, F_s = Γ_sᵀ R_s⁻¹ Γ_s (Γ_s the rows of station s over the
N instants). Without station k, F_(−k) = F − F_k; it is summed here as Σ_{s≠k} F_s, the same
matrix without the cancellation of a subtraction (near station k, F_k exceeds the others by many
decades). Γ is built once per point; each loss is then a 7 × 7 factorisation, not a new map.

Numerics. F_(−k) is column-scaled to unit diagonal (A = D⁻¹ F D⁻¹, D² = diag F: the scaling of
the kernels' Γ_s) and factorised by Cholesky, Γ's rows built in the same compiled kernel
(:func:`core.kernels.loss.loss_measures`, as the Fisher map's, never stored). The condition number of
A is at most n · trace(A⁻¹); where that bound exceeds :data:`KAPPA_MAX` (a normal-equations
inverse would lose more than ~1e-10 of its digits), or the factorisation breaks down, the point
is done exactly as :func:`core.crlb_maps` does it: the rank by the one criterion
(:func:`core.observable_rank`'s SVD of the column-scaled Γ_(−k)) and the covariance from the QR
of Γ_(−k). So the loss map equals a recomputation with the station removed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import loss
from ..model import validation
from .crlb import _covariance_flat
from .gamma import _gamma, _options, _svd_rank

__all__: list = []

#: Largest bound on the condition number of the column-scaled F_(−k) trusted to the Cholesky
#: path: its inverse then carries a relative error ≲ κ · ε ≈ 1e-10 (measured at most 3e-11 on
#: a 120² map of 4 stations); beyond it, the exact path.
KAPPA_MAX = 1e6
#: A Cholesky bound on κ(A) = (σ_max/σ_min)² of the column-scaled Γ below this proves full rank
#: by the one criterion (σ_min/σ_max > RANK_RTOL = 1e-10) with three decades to spare: σ_min/σ_max
#: ≥ 1e-7, even with the bound's own round-off (relative κ·ε ≈ 1e-2).
FULL_RANK_KAPPA = 1e14


def _exact_position(states, kept, steps, T, known, sensor, pos, kappa):
    """(P,) CRLB position error (m) of the stations ``kept``, as :func:`core.crlb_maps` computes
    it: the one rank criterion, then the QR of Γ; +inf where unobservable. Where the Cholesky
    bound ``kappa`` (P,) is at most :data:`FULL_RANK_KAPPA`, Γ has full rank without an SVD."""
    g = _gamma(states, kept, T, sensor, steps, known)
    observable = kappa <= FULL_RANK_KAPPA
    unsure = np.flatnonzero(~observable)
    if unsure.size:
        observable[unsure] = _svd_rank(g[unsure]) == g.shape[-1]
    cov = _covariance_flat(states, kept, observable, steps, T, known, sensor)
    free = sensor.free_columns(known)
    err = np.sqrt(np.sum(cov[:, free[pos], free[pos]], axis=1))
    err[~observable] = np.inf
    return err


def _loss_position(states, stations, steps, T, known, sensor):
    """(P, S) CRLB position error (m) at (P, n_states) states clear of every station, with
    station k lost (column k); +inf where the other stations cannot observe the target."""
    stations = validation.stations(stations)
    n_st, npts = stations.shape[0], states.shape[0]
    free = sensor.free_columns(known)
    pos = [q for q, j in enumerate(free) if j < 3]
    out = np.full((npts, n_st), np.inf)
    if n_st == 1 or npts == 0:
        return out  # no station left
    options, n_rows, noise = _options(stations, T, sensor, known, steps)
    inv_diag, kappa = np.empty((npts, n_st, free.size)), np.empty((npts, n_st))
    loss.loss_measures(np.ascontiguousarray(states), *options, n_rows, inv_diag, kappa)
    out[:] = np.sqrt(inv_diag[:, :, pos].sum(axis=-1)) * noise  # F⁻¹ = noise² (ΓᵀΓ)⁻¹
    # NaN: the target meets a station at a later instant (the kernels' mask): left NaN
    for k in range(n_st):  # the ill-conditioned and the singular: exactly (module notes)
        exact = np.flatnonzero(~(kappa[:, k] <= KAPPA_MAX) & ~np.isnan(kappa[:, k]))
        if exact.size:
            out[exact, k] = _exact_position(states[exact], np.delete(stations, k, axis=0), steps,
                                            T, known, sensor, pos, kappa[exact, k])
    return out


@dataclass(frozen=True)
class StationLoss:
    """Result of :func:`core.station_loss`: what the loss of any one station does.

    Attributes
    ----------
    worst : ndarray, shape (n, n)
        CRLB position error (m) at each region point with the most damaging single station
        lost (the largest over k); +inf where some loss leaves the point unobservable, NaN on
        stations. Rows follow the region's second axis, columns x, as :class:`core.MapResult`.
    worst_station : ndarray of int, shape (n, n)
        The station whose loss is worst there (its row in ``stations``); −1 on stations.
    per_station : ndarray, shape (S, n, n)
        CRLB position error (m) with station k lost.
    coverage_left : ndarray, shape (S,)
        Fraction of the region's off-station points with error ≤ threshold without station k.
    coverage_n1 : float
        Fraction with error ≤ threshold whichever one station is lost (``worst`` ≤ threshold):
        the ``"area_crlb_n1"`` criterion.
    threshold : float
        The threshold T (m).
    """

    worst: np.ndarray
    worst_station: np.ndarray
    per_station: np.ndarray
    coverage_left: np.ndarray
    coverage_n1: float
    threshold: float


def loss_maps(states, clear, stations, n, threshold, steps, T, known, sensor):
    """:class:`StationLoss` of (n·n, n_states) region states, ``clear`` (n·n,) off stations."""
    per = np.full((states.shape[0], stations.shape[0]), np.nan)
    per[clear] = _loss_position(states[clear], stations, steps, T, known, sensor)
    worst = per.max(axis=1)
    which = np.where(clear, np.argmax(np.where(np.isnan(per), -np.inf, per), axis=1), -1)
    return StationLoss(
        worst=worst.reshape(n, n), worst_station=which.reshape(n, n),
        per_station=np.moveaxis(per, 1, 0).reshape(-1, n, n),
        coverage_left=np.mean(per[clear] <= threshold, axis=0),
        coverage_n1=float(np.mean(worst[clear] <= threshold)), threshold=float(threshold))
