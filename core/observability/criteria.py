"""Region criteria of a station layout (:func:`layout_criterion`, :data:`CRITERIA`, spec §13):
D (mean or worst D-optimal measure), A (mean CRLB position error), E (the worst direction),
coverage (the share with CRLB position error ≤ T), the worst point, and coverage with any one
station lost (N−1). Larger is better for every one of them (the errors are negated).

Unobservable points
-------------------
Where Γ is structurally rank-deficient (:func:`core.observable_rank` < n, the flag of
:func:`core.fisher_measures`), F is singular: the CRLB is +inf and the D-optimal measure −inf.
Region criteria cannot average −inf, so :func:`layout_criterion` counts such a point at its
**D-optimal floor**, the value it would have at the largest η a rank-deficient Γ_s can have,
η_max = RANK_RTOL·√(e·n) (σ_min ≤ RANK_RTOL·σ_max, σ_max ≤ √n, and Π of the other n − 1
singular values ≤ √e, all for unit columns):

    floor = log10(η_max) + Σ_j log10 ‖Γ_j‖ − n·log10(noise),

the largest D-optimal value that float64 round-off could fake at that point (D-opt =
log10 η + Σ log10‖Γ_j‖ − n log10 noise where observable). The criterion stays finite and the
floor grows with the column norms, so an optimiser sees a slope; an observable point may lie
below it (η measures volume, not rank), so :attr:`CriterionResult.observable_fraction` says how
much of the region is truly observable. Every other criterion counts an unobservable point
as an infinite error (spec §13): it fails every threshold, and A, E and the worst point are −inf.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import sensors, validation
from .crlb import _covariance_flat, _plane_states
from .fisher import DEFAULT_STEPS, fisher_measures
from .gamma import RANK_RTOL, _gamma
from .grids import Plane
from .loss import _loss_position

__all__ = ["CRITERIA", "CriterionResult", "layout_criterion"]

#: Region criteria: name -> (label, unit). Larger is better for every one of them.
CRITERIA = {
    "mean_dopt": ("mean D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "worst_dopt": ("worst (minimum) D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "mean_crlb": ("minus the mean CRLB position error over the region (A)", "m"),
    "worst_direction": ("mean log10 of the smallest eigenvalue of the position information, the "
                        "worst direction (E)", "log10(1/m²)"),
    "area_crlb": ("fraction of the region with CRLB position error ≤ threshold", "dimensionless"),
    "worst_crlb": ("minus the largest CRLB position error over the region (worst point)", "m"),
    "area_crlb_n1": ("fraction of the region with CRLB position error ≤ threshold whichever one "
                     "station is lost (N−1 coverage)", "dimensionless"),
}


@dataclass(frozen=True)
class CriterionResult:
    """A layout's criterion over a region.

    Attributes
    ----------
    value : float
        The criterion (see :data:`CRITERIA`); larger is better.
    observable_fraction : float
        Fraction of the region's (off-station) points that are observable.
    """

    value: float
    observable_fraction: float


def _check_criterion(criterion, threshold):
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {sorted(CRITERIA)}; got {criterion!r}")
    return validation.positive("threshold", threshold, "m")


def _region_states(region, velocity, moments, sensor=None):
    if not isinstance(region, Plane):
        raise ValueError(
            "region must be a core.Plane (an x–y rectangle at a target depth, or an x–z band of "
            f"depths); got {type(region).__name__}"
        )
    return _plane_states(region, velocity, moments, sensor)


def _criterion(states, stations, criterion, threshold, steps, T, known, sensor):
    """Criterion over (P, n_states) region states of ``sensor``; points on a station are left
    out."""
    states = states[sensor.clear(states, stations, steps, T)]
    if states.shape[0] == 0:
        raise ValueError("every point of the region lies on a station; nothing to evaluate")
    if criterion == "area_crlb_n1":
        worst = _loss_position(states, stations, steps, T, known, sensor).max(axis=1)
        frac = float(np.mean(np.isfinite(worst)))
        return CriterionResult(float(np.mean(worst <= threshold)), frac)
    m = fisher_measures(states, stations, steps=steps, T=T, known=known, sensor=sensor)
    frac = float(np.mean(m.observable))
    err = m.position_std  # +inf where unobservable (spec §13: an infinite error)
    if criterion == "area_crlb":
        return CriterionResult(float(np.mean(err <= threshold)), frac)
    if criterion in ("mean_crlb", "worst_crlb"):
        return CriterionResult(-float(np.mean(err) if criterion == "mean_crlb" else np.max(err)),
                               frac)
    if criterion == "worst_direction":
        return CriterionResult(float(np.mean(_log10_lambda_min(states, stations, m.observable,
                                                               steps, T, known, sensor))), frac)
    d_opt = m.d_optimal.copy()
    bad = np.flatnonzero(~m.observable)
    if bad.size:  # the D-optimal floor of the module notes (R^-½ Γ of a magnetic kind: noise 1)
        _, noise = sensor.kernel_rows()
        g = _gamma(states[bad], stations, T, sensor, steps, known)
        with np.errstate(divide="ignore"):
            log_norms = np.sum(np.log10(np.linalg.norm(g, axis=-2)), axis=-1)
        n = g.shape[-1]
        d_opt[bad] = np.log10(RANK_RTOL * np.sqrt(np.e * n)) + log_norms - n * np.log10(noise)
    value = np.mean(d_opt) if criterion == "mean_dopt" else np.min(d_opt)
    return CriterionResult(float(value), frac)


def _log10_lambda_min(states, stations, observable, steps, T, known, sensor):
    """(P,) log10 λ_min of the position information F_pos = (Cov_pos)⁻¹ (1/m²), the Schur
    complement of F's position block: −log10 λ_max of the CRLB's position block; −inf where
    unobservable or where no position state is unknown."""
    free = sensor.free_columns(known)
    pos = [j for j in free if j < 3]
    out = np.full(states.shape[0], -np.inf)
    if not pos or not np.any(observable):
        return out
    cov = _covariance_flat(states, stations, observable, steps, T, known, sensor)
    block = cov[observable][:, pos][:, :, pos]  # (p, k, k), k ≤ 3 position states
    out[observable] = -np.log10(np.linalg.eigvalsh(block)[:, -1])
    return out


def layout_criterion(stations, region, *, velocity=(2.0, 2.0), moments=(100.0, 20.0),
                     criterion="mean_dopt", threshold=10.0, noise=None,
                     steps=DEFAULT_STEPS, T=1.0, sigma=None, model=None, sea=None, known=(),
                     sensor=None):
    """How well a station layout covers a surveillance region.

    Parameters
    ----------
    stations : array_like, shape (S, 3)
        Station positions (m).
    region : core.Plane
        ``"xy"``: rectangle of target positions at depth ``fixed`` (m); ``"xz"``: x–z band of
        depths at y = ``fixed``.
    velocity, moments
        As for :func:`core.evaluate_map`, the same at every region point.
    criterion : str
        One of :data:`CRITERIA` (docs/survey-design.md), larger is better; e is the CRLB
        position error sqrt(σx² + σy² + σz²) (m) at each region point:

        - ``"mean_dopt"`` (D): mean of ½ log10 det F; ``"worst_dopt"``: its minimum;
        - ``"mean_crlb"`` (A): −mean e (m);
        - ``"worst_direction"`` (E): mean log10 λ_min(F_pos) (log10 of 1/m²), F_pos the
          position information (the Schur complement of F's position block);
        - ``"area_crlb"`` (coverage): the fraction of points with e ≤ ``threshold``;
        - ``"worst_crlb"`` (worst point): −max e (m);
        - ``"area_crlb_n1"`` (N−1 coverage): the fraction with e ≤ ``threshold`` whichever one
          station is lost (:func:`core.station_loss`).

        Unobservable points count at their D-optimal floor (D, module notes) or as an infinite
        error (every other criterion).
    threshold : float
        Position error threshold T (m) of the coverage criteria, > 0.
    noise, steps, T, sigma, model, sea, known, sensor
        As for :func:`crlb_covariance`.

    Returns
    -------
    CriterionResult
        Points within ``ON_STATION`` of a station are left out.

    Examples
    --------
    >>> import core
    >>> region = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 11)
    >>> one = core.layout_criterion(core.single_station(100), region)
    >>> two = core.layout_criterion(core.dual_station(100, 15), region)
    >>> one.observable_fraction, two.observable_fraction, two.value > one.value
    (0.0, 1.0, True)
    """
    threshold = _check_criterion(criterion, threshold)
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    return _criterion(_region_states(region, velocity, moments, sensor),
                      validation.stations(stations), criterion, threshold, steps,
                      validation.positive("T", T, "s"), known, sensor)
