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

from ..kernels import measures
from ..model import sensors
from .gamma import _full_rank, _gamma, _prepare

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
                    sigma=None, model=None, sea=None, known=(), sensor=None):
    """D-optimal measure and Cramér–Rao bounds at every state.

    Parameters
    ----------
    states, stations, T, known, sensor
        As for :func:`core.gamma`.
    sigma, model, sea
        Deprecated, as for :func:`core.crlb_covariance`.
    noise : float or None
        Sensor noise standard deviation on each component, > 0: V/m (electric; None is
        :data:`DEFAULT_NOISE`), nT (B), nT/m (G), (nT, nT/m) (BG). None: the sensor's own.
    steps : int
        Number of instants N ≥ 1 (all rows of all stations).

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
    args, n_rows, lead, scale = _prepare(states, stations, T, sensor, known, steps)
    m = _fisher_from_kernel(args[0], args[1:], n_rows, scale, sensor.state_names)
    return FisherMeasures(**{k: v if k == "free" else v.reshape(lead + v.shape[1:])
                             for k, v in vars(m).items()})


def _fisher_from_kernel(states, options, n_rows, noise, names):
    """Run the compiled kernel on (P, n_states) valid states; FisherMeasures with flat (P,)
    arrays. ``noise``: the noise left to apply outside the kernel (1 for whitened rows),
    ``names``: the state names."""
    npts, free = states.shape[0], options[-1]
    log_eta, log_norms, inv_diag = np.empty(npts), np.empty(npts), np.empty((npts, free.size))
    log_rcond = np.empty(npts)
    measures.fisher_measures(states, *options, n_rows, log_eta, log_norms, inv_diag, log_rcond)
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
        free=tuple(names[j] for j in free),
    )


def fisher_information(states, stations, *, noise=None, steps=DEFAULT_STEPS, T=1.0,
                       sigma=None, model=None, sea=None, known=(), sensor=None):
    """Fisher information matrix F = Γᵀ R⁻¹ Γ, R = diag(noise²) of each component.

    Parameters are those of :func:`fisher_measures`.

    Returns
    -------
    ndarray, shape (..., n, n)
        In 1 / (state unit × state unit), n = 7 − len(known) (8 − len(known) magnetic).
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    _, scale = sensor.kernel_rows()
    g = _gamma(states, stations, T, sensor, steps, known)  # R^-½ Γ of a magnetic kind
    return np.einsum("...ri,...rj->...ij", g, g) / scale**2  # (..., n, n)
