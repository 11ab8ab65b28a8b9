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

from . import validation
from .fields import MODELS, field_jacobian

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
    _rows: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "stations", validation.stations(self.stations))
        if isinstance(self.axes, bool) or self.axes not in AXES:
            raise ValueError(f"axes must be 3 (Ex, Ey, Ez) or 2 (Ex, Ey horizontal); got {self.axes!r}")
        object.__setattr__(self, "axes", int(self.axes))
        object.__setattr__(self, "noise", validation.positive("noise", self.noise, "V/m"))
        object.__setattr__(self, "sigma", validation.positive("sigma", self.sigma, "S/m"))
        validation.model_code(self.model, MODELS)
        n_s = self.stations.shape[0]
        rows = (3 * np.arange(n_s)[:, None] + np.arange(self.axes)[None, :]).ravel()
        object.__setattr__(self, "_rows", rows)  # indices into the flattened (S·3) components

    @property
    def n_meas(self):
        """Length m of the measurement vector, S · axes."""
        return self._rows.size

    @property
    def R(self):
        """Measurement noise covariance noise² I, shape (m, m), (V/m)²."""
        return self.noise**2 * np.eye(self.n_meas)

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
        """∂h/∂X of the measurement at ``states`` (..., 7): shape (..., m, 7)."""
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
        h = J[..., 5] * states[..., None, 5] + J[..., 6] * states[..., None, 6]
        return h, J

    def h(self, states):
        """Noise-free measurement h(X) at ``states`` (..., 7): shape (..., m), V/m."""
        return self.h_and_jacobian(states)[0]
