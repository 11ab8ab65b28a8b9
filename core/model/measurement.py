"""What the sensors report: the measurement model of tracking filters and bounds (spec §8).

A :class:`SensorModel` is a list of stations, how many field axes each reports (3, or 2 for
seed 001's horizontal trial sensors), the noise σ per axis (R = σ² I) and the medium. It has no
field of its own: every value and Jacobian comes from :func:`core.field_jacobian` (one
measurement model for maps, bounds and filters), with the E_z rows dropped for 2-axis sensors.

Measurement vector order: station-major, then component: ``(Ex₁, Ey₁[, Ez₁], Ex₂, …)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import magnetic, validation
from .fields import field_jacobian
from .sensors import Sensor

__all__ = ["AXES", "SensorModel"]

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
    noise : float
        Noise standard deviation per axis (V/m), > 0; R = noise² I.
    sigma : float
        Sea conductivity (S/m), > 0.
    sea : core.Sea or None
        Layered sea (air / water / seabed, spec §7), passed straight to the core's field;
        None is the homogeneous whole space.
    model : {"exact", "paper"}
        Field model of :func:`core.dipole_field`.
    kind : {"E", "B", "G", "BG"}
        Sensor kind of :class:`core.Sensor`: the magnetic kinds take states (..., 8) and noise
        in nT (B), nT/m (G) or a pair (BG); they report all their components (``axes`` = 3).
    baseline : float or None
        A gradiometer's baseline (m), as for :func:`core.gradient_tensor`.

    Examples
    --------
    >>> import core
    >>> m = core.SensorModel([[0, -5, 8.4], [0, 5, 8.4]], axes=2)
    >>> m.n_meas, m.R.shape
    (4, (4, 4))
    """

    stations: np.ndarray
    axes: int = 3
    noise: float = 1e-7
    sigma: float = 4.0
    sea: object = None
    model: str = "exact"
    kind: str = "E"
    baseline: object = None
    _rows: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "stations", validation.stations(self.stations))
        if isinstance(self.axes, bool) or self.axes not in AXES:
            raise ValueError(f"axes must be 3 (Ex, Ey, Ez) or 2 (Ex, Ey horizontal); got {self.axes!r}")
        object.__setattr__(self, "axes", int(self.axes))
        sensor = self.sensor  # validates kind, noise, sigma, sea, model, baseline together
        if sensor.magnetic and self.axes != 3:
            raise ValueError(f"axes=2 is for the electric kind only; sensor kind {self.kind!r} "
                             "reports all its components")
        if not sensor.magnetic:
            object.__setattr__(self, "noise", sensor.noise_vector[0])
        object.__setattr__(self, "sigma", float(self.sigma))
        n_s, n_c = self.stations.shape[0], sensor.n_components
        rows = (n_c * np.arange(n_s)[:, None] + np.arange(min(self.axes, n_c) if not sensor.magnetic
                                                           else n_c)[None, :]).ravel()
        object.__setattr__(self, "_rows", rows)  # indices into the flattened (S·C) components

    @property
    def sensor(self):
        """The :class:`core.Sensor` of this model (kind, noise, medium, baseline)."""
        return Sensor(self.kind, self.noise, self.sigma, self.sea, self.model, self.baseline)

    @property
    def n_states(self):
        """State size: 7 (electric) or 8 (magnetic kinds)."""
        return 8 if self.kind != "E" else 7

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

    def _core_kwargs(self):
        kw = dict(sigma=self.sigma, model=self.model)
        if self.sea is not None:  # only when given: the whole-space core needs no sea argument
            kw["sea"] = self.sea
        return kw

    def jacobian(self, states):
        """∂h/∂X of the measurement at ``states`` (..., n): shape (..., m, n), n = 7 or 8."""
        if self.kind != "E":
            _, J = magnetic.magnetic_jacobian(states, self.stations, sensor=self.kind,
                                              baseline=self.baseline)  # (..., S, C, 8)
            return J.reshape(J.shape[:-3] + (-1, 8))
        J = field_jacobian(states, self.stations, **self._core_kwargs())  # (..., S, 3, 7)
        J = J.reshape(J.shape[:-3] + (-1, 7))  # (..., S·3, 7), station-major
        return J[..., self._rows, :]

    def h_and_jacobian(self, states):
        """Noise-free measurement h(X) (..., m) and ∂h/∂X (..., m, 7) from one core call.

        The field is linear in the moments at fixed position and heading (any linear medium,
        whole space or layered), so ``h = ∂h/∂Ph · Ph + ∂h/∂Pv · Pv`` exactly: the Jacobian's
        moment columns give the field itself (checked against :func:`core.dipole_field` in the
        tests).
        """
        states = np.asarray(states, dtype=float)
        J = self.jacobian(states)
        if J.shape[-1] == 7:
            h = J[..., 5] * states[..., None, 5] + J[..., 6] * states[..., None, 6]
        else:  # the moment vector (mx, my, mz): B and G are linear in it too
            h = np.einsum("...mk,...k->...m", J[..., 5:], states[..., 5:])
        return h, J

    def h(self, states):
        """Noise-free measurement h(X) at ``states`` (..., 7): shape (..., m), V/m."""
        return self.h_and_jacobian(states)[0]
