"""The measurement model: which sensor kind measures, in which medium, with what noise.

One object, :class:`Sensor`, describes what a station measures: the kind (``"E"`` electric,
``"B"`` 3-axis magnetometer, ``"G"`` gradiometer, ``"BG"`` both), the noise per kind, the
electric field formula, the medium (σ, or a :class:`core.Sea`) and a gradiometer's baseline
(docs/measurement-model.md). Every kind goes through the same compiled pipeline: a kind only
picks its rows, in :meth:`Sensor.kernel_rows` here and in the kernels' rows dispatch. The
medium keywords ``sigma``, ``model``, ``sea`` beside ``sensor=`` are a deprecated convenience
that builds the same Sensor (:func:`sensor_model`), except on the spec's stable trio.
"""

from __future__ import annotations

import inspect
import os
import warnings
from dataclasses import dataclass

import numpy as np

from ..kernels.electric import N_COMPONENTS as ELECTRIC_COMPONENTS
from . import magnetic, validation
from .fields import MODELS
from .kinds import SPECS
from .sea import Sea

__all__ = ["KINDS", "MAGNETIC_NOISE", "Sensor", "sensor_model"]

#: Sensor kinds: name -> (what it measures, components per station, noise unit). The counts
#: come from the kernels that compute them (:data:`core.kernels.electric.N_COMPONENTS`, the
#: magnetic components of :mod:`core.model.magnetic`): 3, 3, 5, 8.
KINDS = {
    "E": ("electric field (Ex, Ey, Ez)", ELECTRIC_COMPONENTS, "V/m"),
    "B": ("magnetic field (Bx, By, Bz)", len(magnetic.MAGNETIC_COMPONENTS["B"]), "nT"),
    "G": ("gradient tensor (Gxx, Gxy, Gxz, Gyy, Gyz)", len(magnetic.MAGNETIC_COMPONENTS["G"]),
          "nT/m"),
    "BG": ("magnetic field and gradient tensor", len(magnetic.MAGNETIC_COMPONENTS["BG"]),
           "nT and nT/m"),
}
#: Default noise of the magnetic kinds: (magnetometer nT, gradiometer nT/m). Seed 003's
#: gradiometer noise is 0.01 (nT/m assumed); the magnetometer's is taken equal in nT.
MAGNETIC_NOISE = (0.01, 0.01)
#: Default electric noise (V/m) per component, as core.DEFAULT_NOISE.
ELECTRIC_NOISE = 1e-7


@dataclass(frozen=True)
class Sensor:
    """What every station measures, and in which medium.

    Parameters
    ----------
    kind : {"E", "B", "G", "BG"}
        Electric field (V/m), magnetometer (nT), gradiometer (nT/m) or both magnetic kinds.
    noise : float or (float, float) or None
        Noise standard deviation per component: V/m for ``E``, nT for ``B``, nT/m for ``G``,
        (nT, nT/m) for ``BG``. None: :data:`ELECTRIC_NOISE` or :data:`MAGNETIC_NOISE`.
    sigma : float
        Sea conductivity (S/m), > 0; the electric kinds' medium (a static magnetic field does
        not see it).
    sea : core.Sea or None
        Layered sea (electric kinds); None is the whole space.
    model : {"exact", "paper"}
        Electric field formula.
    baseline : float or None
        A gradiometer's baseline L (m): None or 0 is the point tensor, L > 0 the differences of
        its magnetometers (:func:`core.gradient_tensor`).

    Examples
    --------
    >>> import core
    >>> s = core.Sensor("BG", noise=(0.1, 0.01))
    >>> s.n_components, s.n_states, s.noise_vector
    (8, 8, (0.1, 0.1, 0.1, 0.01, 0.01, 0.01, 0.01, 0.01))
    """

    kind: str = "E"
    noise: object = None
    sigma: float = 4.0
    sea: object = None
    model: str = "exact"
    baseline: object = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"sensor kind must be one of {list(KINDS)} (or a core.Sensor); got {self.kind!r}")
        validation.positive("sigma", self.sigma, "S/m")
        validation.model_code(self.model, MODELS)
        if self.sea is not None and not isinstance(self.sea, Sea):
            raise ValueError(f"sea must be None or a core.Sea; got {type(self.sea).__name__}")
        magnetic.baseline_value(self.baseline)
        SPECS[self.kind].check(self)
        self.noise_vector  # validates

    @property
    def magnetic(self):
        """True for the magnetic kinds B, G, BG."""
        return SPECS[self.kind].magnetic

    @property
    def n_components(self):
        """Measured components per station: 3 (E, B), 5 (G), 8 (BG)."""
        return KINDS[self.kind][1]

    @property
    def n_states(self):
        """State size: 7 (electric ``[x, y, z, vx, vy, Ph, Pv]``) or 8 (``[…, mx, my, mz]``)."""
        return SPECS[self.kind].n_states

    @property
    def state_names(self):
        """Names of the state entries, in order."""
        return SPECS[self.kind].state_names

    @property
    def noise_vector(self):
        """Noise standard deviation of each component of one station (tuple of floats)."""
        unit = KINDS[self.kind][2]
        if self.kind == "BG":
            pair = MAGNETIC_NOISE if self.noise is None else self.noise
            if np.ndim(pair) != 1 or len(pair) != 2:
                raise ValueError(f"noise of kind 'BG' must be (nT, nT/m); got {self.noise!r}")
            nb = validation.positive("noise (B)", pair[0], "nT")
            ng = validation.positive("noise (G)", pair[1], "nT/m")
            n_b = len(magnetic.MAGNETIC_COMPONENTS["B"])
            return (nb,) * n_b + (ng,) * (self.n_components - n_b)
        default = {"E": ELECTRIC_NOISE, "B": MAGNETIC_NOISE[0], "G": MAGNETIC_NOISE[1]}[self.kind]
        value = validation.positive("noise", default if self.noise is None else self.noise, unit)
        return (value,) * self.n_components

    def measure(self, states, stations):
        """Noise-free measurement h(X) and its Jacobian ∂h/∂X at ``states``: the one
        measurement model of maps, bounds and filters.

        Parameters
        ----------
        states : array_like, shape (..., n)
            n = :attr:`n_states` (7 electric, 8 magnetic).
        stations : array_like, shape (S, 3)

        Returns
        -------
        h : ndarray, shape (..., S, C)
            C = :attr:`n_components`; V/m, nT, nT/m.
        H : ndarray, shape (..., S, C, n)

        Notes
        -----
        Electric: :func:`core.field_jacobian`, and h from its moment columns (the field is
        linear in (Ph, Pv) at fixed position and heading, in any linear medium: exact, checked
        against :func:`core.dipole_field` in the tests). Magnetic:
        :func:`core.magnetic_jacobian`.

        Examples
        --------
        >>> import core
        >>> h, H = core.Sensor("G").measure([3, 4, 5, 1, 0, 10, 20, 30], [[0, 0, 0]])
        >>> h.shape, H.shape
        ((1, 5), (1, 5, 8))
        """
        return SPECS[self.kind].measure(self, states, stations)

    @property
    def near(self):
        """Targets closer than this to a station (m) are on it: ON_STATION, or a gradiometer's
        baseline (its magnetometers sit ±L/2 about the station)."""
        if "G" in self.kind:
            return max(validation.ON_STATION, magnetic.baseline_value(self.baseline))
        return validation.ON_STATION

    def kernel_rows(self, whiten=True):
        """The rows arguments ``(kappa, code, medium)`` of :mod:`core.kernels.gamma` (the one
        place where a kind picks its rows) and the noise left to apply outside the kernels.

        Electric: κ = 1/(4πσ), the field model's code, the medium of :func:`core.model.sea.medium`;
        its rows share one noise, applied outside (returned). Magnetic: the kind's code and
        [near, baseline, 1/noise_B, 1/noise_G], so that the rows come whitened (R^-½ H: B in nT
        and G in nT/m made commensurate) and the noise outside is 1; ``whiten=False`` gives
        the rows themselves (weights 1).
        """
        return SPECS[self.kind].kernel_rows(self, whiten)

    def states(self, value):
        """Validated states of this kind as a contiguous (P, n_states) array, and the leading
        shape (electric states need a speed > 0: the field's heading is the velocity's)."""
        return SPECS[self.kind].states(value)

    def check_column(self, states, stations):
        """ValueError if targets or stations lie outside the medium's water column (a layered
        sea); a magnetostatic field does not see the sea."""
        SPECS[self.kind].check_column(self, states, stations)

    def check_clear(self, states, stations, steps, T):
        """ValueError if a target (P, n_states) is on a station: electric, at the first instant
        (the kernels give NaN later); magnetic, within :attr:`near` at any of the ``steps``
        instants."""
        SPECS[self.kind].check_clear(self, states, stations, steps, T)

    def clear(self, states, stations, steps, T):
        """(P,) True where a target (P, n_states) is off every station: electric, at the first
        instant; magnetic, farther than :attr:`near` at every instant of Γ."""
        n = SPECS[self.kind].clear_instants(steps)
        T = validation.positive("T", T, "s")
        clear = np.ones(states.shape[0], dtype=bool)
        for i in range(n):
            moved = states[:, :3].copy()
            moved[:, :2] += i * T * states[:, 3:5]
            clear &= np.min(validation.station_distances(moved, stations), axis=1) >= self.near
        return clear

    def bank_moments(self, strength, strength_frac, pv_std):
        """Moment entries of seed 001's filter-bank hypotheses of strength p (..., H) and their
        prior σ: (mean, std), each (..., H, n_states − 5).

        Electric: (Ph, Pv) = (p, 0), σ = (strength_frac·p, pv_std) (seed 001: a horizontal
        dipole along the motion). Magnetic: (mx, my, mz) = (0, 0, p), a vertical moment (depth
        down: the induced moment of a hull under a mostly vertical geomagnetic field; a
        permanent moment's direction is not known beforehand), σ = strength_frac·p on each
        component, wide enough for any direction of strength ≤ p within ~2σ."""
        return SPECS[self.kind].bank_moments(np.asarray(strength, float)[..., None], strength_frac, pv_std)

    def free_columns(self, known):
        """Indices of the unknown states, given the names of the known ones."""
        return validation.free_columns(known, self.state_names)


def sensor_model(sensor=None, *, sigma=None, model=None, sea=None, noise=None, warn=True):
    """The :class:`Sensor` of a call: ``sensor`` (a kind name or a Sensor) or, when None, the
    electric one, built from the medium keywords ``sigma``, ``model``, ``sea`` (None: 4 S/m, the
    exact field, the whole space). An object given together with non-default medium keywords is
    a ValueError (two descriptions of one measurement).

    The medium keywords beside ``sensor=`` are deprecated in every public function but the
    spec's stable trio (:func:`core.gamma`, :func:`core.log10_abs_det_gamma`,
    :func:`core.observable_rank`, which pass ``warn=False``): given (not None), they emit a
    DeprecationWarning pointing at the caller outside :mod:`core`, and build the same Sensor as
    ``sensor=core.Sensor("E", noise, sigma, sea, model)``."""
    given = [name for name, v in (("sigma", sigma), ("model", model), ("sea", sea)) if v is not None]
    if given and warn:
        warnings.warn(
            f"{', '.join(n + '=' for n in given)} beside sensor= are deprecated: describe the "
            "measurement once, as sensor=core.Sensor('E', noise, sigma, sea, model)",
            DeprecationWarning, stacklevel=_outside_core())
    sigma = 4.0 if sigma is None else sigma
    model = "exact" if model is None else model
    if isinstance(sensor, Sensor):
        if sigma != 4.0 or model != "exact" or sea is not None:
            raise ValueError(
                "pass the medium either in the core.Sensor or as sigma=/model=/sea=, not both; "
                f"got sensor={sensor!r} and sigma={sigma!r}, model={model!r}, sea={sea!r}"
            )
        return sensor if noise is None else Sensor(sensor.kind, noise, sensor.sigma, sensor.sea,
                                                   sensor.model, sensor.baseline)
    if sensor is None:
        sensor = "E"
    if not isinstance(sensor, str):
        raise ValueError(f"sensor must be one of {list(KINDS)} or a core.Sensor; got {sensor!r}")
    if sensor == "E":
        return Sensor("E", noise, sigma, sea, model)
    if sigma != 4.0 or model != "exact" or sea is not None:
        raise ValueError(f"sensor kind {sensor!r} is magnetic: sigma, model and sea are electric "
                         f"options; got sigma={sigma!r}, model={model!r}, sea={sea!r}")
    return Sensor(sensor, noise)


def _outside_core():
    """``warnings.warn``'s stacklevel, counted from :func:`sensor_model`, of the first caller
    outside the :mod:`core` package (the user's line, however deep the public call)."""
    core_dir = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
    frame, level = inspect.currentframe().f_back, 1  # sensor_model's frame
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(core_dir):
        frame, level = frame.f_back, level + 1
    return level


def refuse_square(sensor, what):
    """ValueError for the paper's square-Γ rule with a magnetic kind."""
    SPECS[sensor.kind].refuse_square(sensor, what)
