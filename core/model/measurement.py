"""What the sensors report: the measurement model of tracking filters and bounds (spec §8).

A :class:`SensorModel` is a list of stations, how many field axes each reports (3, or 2 for
seed 001's horizontal trial sensors) and one :class:`core.Sensor` (kind, noise per component,
medium, baseline). It has no field of its own: every value and Jacobian comes from
:meth:`core.Sensor.measure` (one measurement model for maps, bounds and filters; electric:
:func:`core.field_jacobian`, magnetic: :func:`core.magnetic_jacobian`), with the E_z rows
dropped for 2-axis electric sensors.

Measurement vector order: station-major, then component: ``(Ex₁, Ey₁[, Ez₁], Ex₂, …)``
(``(Bx₁, By₁, Bz₁, Gxx₁, …)`` for magnetic kinds).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import validation
from .sensors import Sensor, sensor_model

__all__ = ["AXES", "SensorModel", "tracking_sensors"]

#: Accepted numbers of field axes per station: 3 (Ex, Ey, Ez) or 2 (Ex, Ey).
AXES = (2, 3)


@dataclass(frozen=True)
class SensorModel:
    """Stations, axes, noise and medium of a tracking problem.

    Parameters
    ----------
    stations : array_like, shape (S, 3)
        Station positions (m), z the depth (positive down when ``sea`` is given, spec §7).
    axes : {3, 2}
        Field components each station reports: 3 = (Ex, Ey, Ez), 2 = horizontal (Ex, Ey).
    noise, sigma, sea, model, kind, baseline
        The fields of :class:`core.Sensor` (R = diag(noise²); a magnetic ``kind`` takes states
        (..., 8) and reports all its components, ``axes`` = 3).
    sensor : core.Sensor or str or None
        The measurement model as one object (or a kind name with its defaults). Given, it is
        the source of kind, noise, medium and baseline, and those keywords must be left at
        their defaults (two descriptions of one measurement are refused). After construction
        ``sensor`` always holds the :class:`core.Sensor`, and the keyword fields mirror it.

    Examples
    --------
    >>> import core
    >>> m = core.SensorModel([[0, -5, 8.4], [0, 5, 8.4]], axes=2)
    >>> m.n_meas, m.R.shape
    (4, (4, 4))
    >>> g = core.SensorModel([[0, 0, 0], [0.5, 0, 0]], sensor=core.Sensor("G", noise=0.01))
    >>> g.kind, g.n_meas, g.n_states
    ('G', 10, 8)
    """

    stations: np.ndarray
    axes: int = 3
    noise: object = None
    sigma: float = 4.0
    sea: object = None
    model: str = "exact"
    kind: str = "E"
    baseline: object = None
    sensor: object = None
    _rows: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "stations", validation.stations(self.stations))
        if isinstance(self.axes, bool) or self.axes not in AXES:
            raise ValueError(f"axes must be 3 (Ex, Ey, Ez) or 2 (Ex, Ey horizontal); got {self.axes!r}")
        object.__setattr__(self, "axes", int(self.axes))
        if self.sensor is not None:
            if (self.noise is not None or self.sigma != 4.0 or self.sea is not None
                    or self.model != "exact" or self.kind != "E" or self.baseline is not None):
                raise ValueError(
                    "describe the measurement either as sensor= (a core.Sensor or a kind name) or "
                    "with noise=/sigma=/sea=/model=/kind=/baseline=, not both; got "
                    f"sensor={self.sensor!r}"
                )
            sensor = sensor_model(self.sensor)
        else:  # the old keywords build the one Sensor (validates them together)
            sensor = Sensor(self.kind, self.noise, self.sigma, self.sea, self.model, self.baseline)
        object.__setattr__(self, "sensor", sensor)
        for name in ("kind", "sigma", "sea", "model", "baseline"):
            object.__setattr__(self, name, getattr(sensor, name))
        per = sensor.noise_vector  # the noise per component, one value per kind measured
        object.__setattr__(self, "noise", (per[0], per[-1]) if sensor.kind == "BG" else per[0])
        if sensor.magnetic and self.axes != 3:
            raise ValueError(f"axes=2 is for the electric kind only; sensor kind {self.kind!r} "
                             "reports all its components")
        object.__setattr__(self, "sigma", float(self.sigma))
        n_s, n_c = self.stations.shape[0], sensor.n_components
        rows = (n_c * np.arange(n_s)[:, None] + np.arange(min(self.axes, n_c) if not sensor.magnetic
                                                           else n_c)[None, :]).ravel()
        object.__setattr__(self, "_rows", rows)  # indices into the flattened (S·C) components

    @property
    def n_states(self):
        """State size of the sensor kind: 7 (electric) or 8 (magnetic kinds)."""
        return self.sensor.n_states

    @property
    def noise_vector(self):
        """Noise standard deviation of every measured component, shape (m,)."""
        per_station = np.asarray(self.sensor.noise_vector)
        return np.tile(per_station, self.stations.shape[0])[self._rows]

    @property
    def n_meas(self):
        """Length m of the measurement vector, S · axes."""
        return self._rows.size

    @property
    def R(self):
        """Measurement noise covariance diag(noise²), shape (m, m): (V/m)², nT², (nT/m)²."""
        return np.diag(self.noise_vector**2)

    @property
    def depth_range(self):
        """(lowest, highest) depth (m) a target may have: the water column, or (−inf, inf)."""
        depth = getattr(self.sea, "depth", None)
        return (0.0, float(depth)) if depth is not None else (-np.inf, np.inf)

    def jacobian(self, states):
        """∂h/∂X of the measurement at ``states`` (..., n): shape (..., m, n), n the sensor's
        state size (7 electric, 8 magnetic)."""
        return self.h_and_jacobian(states)[1]

    def h_and_jacobian(self, states):
        """Noise-free measurement h(X) (..., m) and ∂h/∂X (..., m, n) from one call of the
        sensor's measurement (:meth:`core.Sensor.measure`)."""
        h, J = self.sensor.measure(states, self.stations)  # (..., S, C), (..., S, C, n)
        n = J.shape[-1]
        J = J.reshape(J.shape[:-3] + (-1, n))[..., self._rows, :]  # station-major
        h = h.reshape(h.shape[:-2] + (-1,))[..., self._rows]
        return h, J

    def h(self, states):
        """Noise-free measurement h(X) at ``states`` (..., n): shape (..., m), in the sensor's
        units (V/m, nT, nT/m)."""
        return self.h_and_jacobian(states)[0]


def tracking_sensors(sensors, sensor=None, axes=3):
    """The :class:`SensorModel` of a tracking call: ``sensors`` a SensorModel (then ``sensor``
    must be None or its own Sensor), or station positions (S, 3) with ``sensor`` (a
    :class:`core.Sensor` or a kind name; None is the electric default) and ``axes``."""
    if isinstance(sensors, SensorModel):
        if sensor is not None and sensor_model(sensor) != sensors.sensor:
            raise ValueError(
                "sensors is a core.SensorModel, which carries its own Sensor; pass sensor= only "
                f"with station positions (got sensor={sensor!r} and {sensors.sensor!r})"
            )
        return sensors
    if sensors is None:
        raise ValueError("sensors must be a core.SensorModel or station positions (S, 3) in m")
    return SensorModel(sensors, axes=axes, sensor=sensor if sensor is not None else "E")
