"""Region criteria of a station layout (:func:`layout_criterion`, :data:`CRITERIA`): mean or
worst D-optimal measure over a region, or the area whose CRLB position error is below a threshold.

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
much of the region is truly observable. For ``"area_crlb"`` an unobservable point simply
fails the threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import sensors, validation
from .crlb import _plane_states
from .fisher import DEFAULT_STEPS, fisher_measures
from .gamma import RANK_RTOL, _gamma
from .grids import Plane

__all__ = ["CRITERIA", "CriterionResult", "layout_criterion"]

#: Region criteria: name -> (label, unit). Larger is better for every one of them.
CRITERIA = {
    "mean_dopt": ("mean D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "worst_dopt": ("worst (minimum) D-optimal ½·log10 det F over the region", "log10 of F's units"),
    "area_crlb": ("fraction of the region with CRLB position error < threshold", "dimensionless"),
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
    m = fisher_measures(states, stations, steps=steps, T=T, known=known, sensor=sensor)
    frac = float(np.mean(m.observable))
    if criterion == "area_crlb":
        return CriterionResult(float(np.mean(m.position_std < threshold)), frac)
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
    criterion : {"mean_dopt", "worst_dopt", "area_crlb"}
        ``"mean_dopt"``: mean D-optimal measure over the region's points; ``"worst_dopt"``: its
        minimum; ``"area_crlb"``: fraction of the points whose CRLB position error
        sqrt(σx² + σy² + σz²) is below ``threshold``. Unobservable points count at their
        D-optimal floor (module notes) or as failing the threshold.
    threshold : float
        Position error threshold (m) for ``"area_crlb"``, > 0.
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
