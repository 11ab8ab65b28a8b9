"""Measures evaluated over a plane of target positions, and difference maps (spec §5).

Grid points within :data:`core.kernels.electric.ON_STATION` of a station are masked (NaN), not
raised on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import measures
from ..model import sensors
from .crlb import _plane_states
from .fisher import DEFAULT_STEPS, _fisher_from_kernel
from .gamma import _full_rank, _options

__all__ = ["MEASURES", "MapResult", "evaluate_map", "log10_positive_difference", "log10_ratio"]

#: Measure name -> (label, unit, paper rule?).
MEASURES = {
    "log10_det": ("log10|det Γ|", "Γ in (V/m) per state unit", True),
    "log10_eta": ("log10 η (observability index)", "dimensionless", True),
    "d_optimal": ("½·log10 det F (D-optimal)", "F in 1/state unit²", False),
    "crlb_position": ("CRLB position error (1σ, m)", "m", False),
}
CHUNK_POINTS = 1 << 18  # 256 Ki points: one kernel launch up to 512 × 512, 15 MB of states


@dataclass(frozen=True)
class MapResult:
    """A measure over a plane. ``value`` and ``observable`` have shape (n, n): rows follow the
    plane's second axis (y or z), columns x. ``value`` is NaN on stations."""

    value: np.ndarray
    observable: np.ndarray
    measure: str


def evaluate_map(plane, stations, *, velocity, moments, measure="log10_det", T=1.0, sigma=None,
                 model=None, sea=None, known=(), noise=None, steps=DEFAULT_STEPS, sensor=None):
    """Evaluate one measure over a :class:`core.observability.grids.Plane`.

    Parameters
    ----------
    plane : core.observability.grids.Plane
    stations : array_like, shape (S, 3)
        Station positions (m).
    velocity : (vx, vy)
        Target velocity (m/s), speed > 0.
    moments : (Ph, Pv) or (mx, my, mz)
        Dipole moments: (Ph, Pv) A·m for the electric kind, the moment vector A·m² for magnetic.
    measure : {"log10_det", "log10_eta", "d_optimal", "crlb_position"}
        See :data:`MEASURES`. The first two use the paper's square Γ (electric only); the others
        all rows of ``steps`` instants and the sensor ``noise`` (V/m; nT, nT/m magnetic).
    sensor : {"E", "B", "G", "BG"} or core.Sensor or None
        The measurement model, as for :func:`core.gamma`.
    sea : core.Sea or None
        The whole space (``None``) or a layered sea (:mod:`core.model.sea`): then the plane must lie
        in the water column (an x–y plane at 0 ≤ z ≤ D; an x–z plane with 0 ≤ z ≤ D).

    Returns
    -------
    MapResult
        ``value`` is NaN within ``ON_STATION`` of a station. ``observable`` is False there and
        where Γ is structurally rank-deficient (:func:`core.observable_rank` < n, the one
        criterion); there ``log10_det`` still holds float64's round-off value, for display as
        such.

    Notes
    -----
    Rows are evaluated in chunks of at most :data:`CHUNK_POINTS` points, so memory is bounded
    by the outputs for any resolution up to :data:`core.observability.grids.MAX_RESOLUTION`.
    """
    if measure not in MEASURES:
        raise ValueError(f"measure must be one of {sorted(MEASURES)}; got {measure!r}")
    square = MEASURES[measure][2]
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, noise=noise)
    if square:
        sensors.refuse_square(sensor, f"measure {measure!r}")
    options, n_rows, noise = _options(stations, T, sensor, known, None if square else steps)
    _plane_states(plane, velocity, moments, sensor, slice(0, 0))  # validates velocity, moments
    depths = [plane.fixed] if plane.kind == "xy" else list(plane.v)  # the plane's depths
    column = np.zeros((len(depths), sensor.n_states))
    column[:, 2] = depths
    sensor.check_column(column, options[0])
    n = plane.n
    value = np.empty((n, n))
    log_eta = np.empty((n, n))
    observable = np.empty((n, n), dtype=bool)
    rows_per_chunk = max(1, CHUNK_POINTS // n)
    for r0 in range(0, n, rows_per_chunk):
        rows = slice(r0, min(n, r0 + rows_per_chunk))
        states = _plane_states(plane, velocity, moments, sensor, rows)
        eta = log_eta[rows].reshape(-1)  # views: the kernels write straight into the map
        out = value[rows].reshape(-1)
        if square:
            rcond = np.empty(len(states))
            measures.square_measures(states, *options, out if measure == "log10_det" else
                                     np.empty(len(states)), eta, rcond)
            if measure == "log10_eta":
                out[:] = eta
            observable[rows] = _full_rank(rcond, states, options, n_rows).reshape(-1, n)
        else:
            m = _fisher_from_kernel(states, options, n_rows, noise, sensor.state_names)
            eta[:] = m.log10_eta
            out[:] = m.d_optimal if measure == "d_optimal" else m.position_std
            observable[rows] = m.observable.reshape(-1, n)
    return MapResult(value=value, observable=observable, measure=measure)


def log10_positive_difference(log_a, log_b):
    """log10(|det A| − |det B|) from the two logs, NaN where the difference is ≤ 0.

    The paper's difference maps (Figs. 3–6). Computed as
    ``a + log10(1 − 10^(b − a))`` so that nothing underflows however small both are.
    """
    a = np.asarray(log_a, dtype=np.float64)
    b = np.asarray(log_b, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        gap = np.where(np.isneginf(b), -np.inf, b - a)  # ≤ 0 where A > B
        out = a + np.log10(-np.expm1(gap * np.log(10.0)))
    return np.where((a > b) & np.isfinite(a), out, np.nan)


def log10_ratio(log_a, log_b):
    """Signed log-ratio log10|det A| − log10|det B| (NaN where either is not finite)."""
    a = np.asarray(log_a, dtype=np.float64)
    b = np.asarray(log_b, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        out = a - b
    return np.where(np.isfinite(out), out, np.nan)
