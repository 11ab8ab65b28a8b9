"""Fisher information, the D-optimal measure and Cramér–Rao bounds (spec §3, general rule).

With every component of every station over N instants (Γ of shape (3·S·N) × n) and white sensor
noise of standard deviation ``noise`` (V/m) on each component, ``R = noise² I`` and

    F = Γᵀ R⁻¹ Γ,    D-optimal measure = ½ log10 det F,    Cov ≥ F⁻¹ (Cramér–Rao).

Where Γ is structurally rank-deficient (:func:`core.observable_rank` < n) F is singular:
the D-optimal measure is ``-inf`` and every bound is ``+inf``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import gamma as kernels
from ..model import magnetic, sensors, validation
from .gamma import (
    _BRACKET_MARGIN,
    RANK_RTOL,
    _full_rank,
    _prepare,
    _svd_rank,
    gamma,
)

__all__ = ["DEFAULT_NOISE", "DEFAULT_STEPS", "FisherMeasures", "fisher_information", "fisher_measures"]

#: Sensor noise standard deviation (V/m), as in the filter-bank paper (seed 001).
DEFAULT_NOISE = 1e-7
#: Instants used by default for the all-rows Γ.
DEFAULT_STEPS = 3


@dataclass(frozen=True)
class FisherMeasures:
    """Per-point results of :func:`fisher_measures`; every array has the states' leading shape.

    Attributes
    ----------
    d_optimal : ndarray
        ½ log10 det F (F in 1 / state-unit², dimensionless log); -inf where not observable.
    log10_eta : ndarray
        Scale-free observability index log10 sqrt(det Γ_sᵀΓ_s) ≤ 0.
    observable : ndarray of bool
        Full rank: ``core.observable_rank(..., steps=steps) == n`` (the one criterion).
    std : ndarray, shape (..., n)
        CRLB standard deviation of each unknown state (m, m/s, A·m); +inf where not observable.
    position_std : ndarray
        sqrt(σx² + σy² + σz²) over the unknown position states (m); +inf where not observable.
    free : tuple of str
        Names of the unknown states, the order of ``std``'s last axis.
    """

    d_optimal: np.ndarray
    log10_eta: np.ndarray
    observable: np.ndarray
    std: np.ndarray
    position_std: np.ndarray
    free: tuple


def fisher_measures(states, stations, *, noise=None, steps=DEFAULT_STEPS, T=1.0,
                    sigma=4.0, model="exact", sea=None, known=(), sensor=None):
    """D-optimal measure and Cramér–Rao bounds at every state.

    Parameters
    ----------
    states, stations, T, sigma, model, sea, known
        As for :func:`core.gamma`.
    noise : float or None
        Sensor noise standard deviation on each component, > 0: V/m (electric; None is
        :data:`DEFAULT_NOISE`), nT (B), nT/m (G), (nT, nT/m) (BG). None: the sensor's own.
    steps : int
        Number of instants N ≥ 1 (all rows of all stations).
    sensor : {"E", "B", "G", "BG"} or core.Sensor or None
        The measurement model, as for :func:`core.gamma`.

    Returns
    -------
    FisherMeasures

    Examples
    --------
    >>> import core
    >>> m = core.fisher_measures([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]])
    >>> bool(m.observable), m.std.shape
    (True, (7,))
    >>> bool(core.fisher_measures([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]]).observable)
    False
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    if sensor.magnetic:
        m, _, lead = magnetic_fisher(states, stations, sensor, T, steps, known)
    else:
        noise = sensor.noise_vector[0]
        args, n_rows, lead = _prepare(states, stations, T, sensor.sigma, sensor.model, known,
                                      steps, sensor.sea)
        m = _fisher_from_kernel(args[0], args[1:], n_rows, noise)
    return FisherMeasures(
        d_optimal=m.d_optimal.reshape(lead),
        log10_eta=m.log10_eta.reshape(lead),
        observable=m.observable.reshape(lead),
        std=m.std.reshape(lead + (m.std.shape[-1],)),
        position_std=m.position_std.reshape(lead),
        free=m.free,
    )


def _fisher_from_kernel(states, options, n_rows, noise):
    """Run the compiled kernel on (P, 7) valid states; FisherMeasures with flat (P,) arrays."""
    npts, free = states.shape[0], options[-1]
    log_eta, log_norms, inv_diag = np.empty(npts), np.empty(npts), np.empty((npts, free.size))
    log_rcond = np.empty(npts)
    kernels.fisher_measures(states, *options, n_rows, log_eta, log_norms, inv_diag, log_rcond)
    observable = _full_rank(log_rcond, states, options, n_rows)  # False on a station (NaN)
    # ½ log10 det(ΓᵀΓ / noise²) = log10 η + Σ log10‖Γ_j‖ − n log10(noise)
    d_opt = np.where(observable, log_eta + log_norms - free.size * np.log10(noise), -np.inf)
    var = np.where(observable[:, None], inv_diag * noise**2, np.inf)
    pos = [q for q, j in enumerate(free) if j < 3]
    pos_std = np.sqrt(var[:, pos].sum(axis=1)) if pos else np.zeros(npts)
    on_station = np.isnan(log_eta)
    d_opt[on_station], pos_std[on_station] = np.nan, np.nan
    return FisherMeasures(
        d_optimal=d_opt,
        log10_eta=log_eta,
        observable=observable,
        std=np.sqrt(var),
        position_std=pos_std,
        free=tuple(validation.STATE_NAMES[j] for j in free),
    )


def fisher_information(states, stations, *, noise=None, steps=DEFAULT_STEPS, T=1.0,
                       sigma=4.0, model="exact", sea=None, known=(), sensor=None):
    """Fisher information matrix F = Γᵀ R⁻¹ Γ, R = diag(noise²) of each component.

    Parameters are those of :func:`fisher_measures`.

    Returns
    -------
    ndarray, shape (..., n, n)
        In 1 / (state unit × state unit), n = 7 − len(known) (8 − len(known) magnetic).
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    if sensor.magnetic:
        g = sensors.magnetic_gamma(states, stations, sensor, T=T, steps=steps, known=known,
                                   whiten=True)
        return np.einsum("...ri,...rj->...ij", g, g)
    noise = sensor.noise_vector[0]
    g = gamma(states, stations, T=T, steps=steps, known=known, sensor=sensor)
    return np.einsum("...ri,...rj->...ij", g, g) / noise**2  # (..., n, n)


def magnetic_fisher(states, stations, sensor, T, steps, known):
    """Fisher measures of a magnetic kind from the whitened all-rows Γ (numpy: QR of the
    column-scaled Γ, as the electric CRLB covariance). Returns (FisherMeasures with flat (P,)
    arrays, covariance of the free states (P, n, n), leading shape)."""
    flat, lead = magnetic.states(states)
    g = sensors.magnetic_gamma(flat, stations, sensor, T=T, steps=steps, known=known, whiten=True)
    free = sensor.free_columns(known)
    npts, n = flat.shape[0], free.size
    if g.shape[-2] < n:  # fewer rows than unknowns: rank < n everywhere; pad Γ with zero rows
        g = np.concatenate([g, np.zeros(g.shape[:-2] + (n - g.shape[-2], n))], axis=-2)
    norms = np.linalg.norm(g, axis=-2)  # (P, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.linalg.qr(g / norms[:, None, :], mode="r")  # (P, n, n): Γ_s = Q R
        diag = np.abs(np.diagonal(r, axis1=-2, axis2=-1))
        log_eta = np.sum(np.log10(diag), axis=-1)
        log_norms = np.sum(np.log10(norms), axis=-1)
    # The one rank criterion without an SVD per point: rcond = 1 / (‖Γ_s‖_F ‖R⁻¹‖_F), with
    # ‖Γ_s‖_F² = n, brackets σmin/σmax in [rcond, n·rcond] (core.kernels); the thin band where
    # the bracket straddles RANK_RTOL is decided by the SVD, as core.observability.gamma._full_rank.
    invertible = np.all(diag > 0.0, axis=-1) & np.all(np.isfinite(r), axis=(-2, -1))
    idx = np.flatnonzero(invertible)
    rinv = np.full((npts, n, n), np.nan)
    if idx.size:
        rinv[idx] = np.linalg.solve(r[idx], np.broadcast_to(np.eye(n), (idx.size, n, n)))
    with np.errstate(divide="ignore", invalid="ignore"):
        frob2 = np.sum(rinv * rinv, axis=(-2, -1))
        log_rcond = np.where(invertible & np.isfinite(frob2), -0.5 * np.log10(n * frob2), -np.inf)
    observable = log_rcond >= np.log10(RANK_RTOL * _BRACKET_MARGIN)
    unsure = ~observable & (log_rcond + np.log10(n) > np.log10(RANK_RTOL / _BRACKET_MARGIN))
    if np.any(unsure):
        observable[unsure] = _svd_rank(g[unsure]) == n
    cov = np.full((npts, n, n), np.nan)
    cov[:, np.arange(n), np.arange(n)] = np.inf
    idx = np.flatnonzero(observable)
    if idx.size:
        inv_s = rinv[idx] @ np.swapaxes(rinv[idx], -1, -2)  # (Γ_sᵀΓ_s)⁻¹ = R⁻¹ R⁻ᵀ
        cov[idx] = inv_s / (norms[idx, :, None] * norms[idx, None, :])
    var = np.diagonal(cov, axis1=-2, axis2=-1)
    pos = [q for q, j in enumerate(free) if j < 3]
    pos_std = np.sqrt(var[:, pos].sum(axis=1)) if pos else np.zeros(npts)
    m = FisherMeasures(
        d_optimal=np.where(observable, log_eta + log_norms, -np.inf),
        log10_eta=log_eta,
        observable=observable,
        std=np.sqrt(var),
        position_std=pos_std,
        free=tuple(sensor.state_names[j] for j in free),
    )
    return m, cov, lead

