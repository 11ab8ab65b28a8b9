"""The layout problem as one object (:class:`LayoutProblem`): the region, the target, the
measurement, the criterion and the constraints. It is the one way into the layout searches
(:func:`core.spacing_curve`, :func:`core.best_spacing`, :func:`core.optimise_layout`,
:func:`core.station_count_curve`)."""

from __future__ import annotations

from dataclasses import dataclass

from ..model import sensors, validation
from .constraints import LayoutConstraints
from .criteria import _check_criterion, _region_states
from .fisher import DEFAULT_STEPS
from .layouts import station_layout

__all__ = ["LayoutProblem"]


@dataclass(frozen=True)
class LayoutProblem:
    """What a layout is designed for: region, target, measurement, criterion, constraints.

    Parameters
    ----------
    region : core.Plane
        Surveillance region: an x–y rectangle of target positions at depth ``fixed`` (m), or an
        x–z band of depths (see :func:`core.layout_criterion`).
    h : float
        Depth of the new stations (m, z down).
    velocity : (float, float)
        Target velocity (vx, vy) (m/s), the same at every region point; speed > 0 (electric).
    moments : tuple of float
        Target moments: (Ph, Pv) (A·m) electric, (mx, my, mz) (A·m²) magnetic.
    sensor : core.Sensor or str or None
        The measurement (kind, noise, medium, baseline); None: the electric default.
    criterion : str
        One of :data:`core.CRITERIA` (larger is better), e.g. ``"mean_dopt"`` (D).
    threshold : float
        CRLB position error threshold T (m), > 0, of the coverage criteria.
    steps : int
        Instants N ≥ 1 of the all-rows Γ.
    T : float
        Sampling interval (s), > 0.
    known : tuple of str
        States taken as known (see :func:`core.gamma`).
    constraints : core.LayoutConstraints or None
        Fixed stations, forbidden zones, depth band, minimum spacing (see
        :class:`core.LayoutConstraints`); None: no constraint.

    Examples
    --------
    >>> import core
    >>> problem = core.LayoutProblem(core.Plane("xy", (-300, 300), (-300, 300), 120.0, 9))
    >>> core.optimise_layout("line", 2, problem, d_range=(5, 300), n_curve=5).stations.shape
    (2, 3)
    """

    region: object
    h: float = 100.0
    velocity: tuple = (2.0, 2.0)
    moments: tuple = (100.0, 20.0)
    sensor: object = None
    criterion: str = "mean_dopt"
    threshold: float = 10.0
    steps: int = DEFAULT_STEPS
    T: float = 1.0
    known: tuple = ()
    constraints: object = None

    def measurement(self):
        """The problem's :class:`core.Sensor` (validated)."""
        return sensors.sensor_model(self.sensor)

    def prepared(self):
        """Validate the problem; return (region states (P, n_states), sensor, threshold (m),
        h (m), T (s))."""
        sensor = self.measurement()
        threshold = _check_criterion(self.criterion, self.threshold)
        states = _region_states(self.region, self.velocity, self.moments, sensor)
        h = station_layout("line", 1, h=self.h)[0, 2]  # validates h
        validation.steps(self.steps, 1)
        if self.constraints is not None and not isinstance(self.constraints, LayoutConstraints):
            raise ValueError("constraints must be None or a core.LayoutConstraints; got "
                             f"{type(self.constraints).__name__}")
        return states, sensor, threshold, h, validation.positive("T", self.T, "s")


def check_problem(problem):
    """ValueError unless ``problem`` is a :class:`LayoutProblem`."""
    if not isinstance(problem, LayoutProblem):
        raise ValueError("the layout problem must be a core.LayoutProblem(region, h=…, velocity=…, "
                         "moments=…, sensor=…, criterion=…, threshold=…); got "
                         f"{type(problem).__name__}")
    return problem
