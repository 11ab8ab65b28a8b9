"""Seed 001's tracking cases, measured by any sensor kind (run by :mod:`core.tracking.montecarlo`;
their geometry and numbers: docs/tracking.md, *Cases*).

Our frame is x, y, z = depth positive down; seed 001's z-up frame maps by (x, y, z_up) → (x, −y,
D − z_up), its bearings by ψ → −ψ. ``seed001-sim`` is its simulation (whole space, two 3-axis
sensors) on the trial's geometry (its Table 1 is lost); ``seed001-trial`` the same track in the
trial's layered sea with two 2-axis seabed sensors. A :class:`TrackCase` takes ``sensor=`` (a
:class:`core.Sensor` or a kind name; the old keywords ``noise``, ``sigma``, ``sea_depth``,
``seabed_sigma`` build the electric one) and, for a magnetic kind, ``moments=(mx, my, mz)``
(A·m²) and an 8-entry ``prior_std`` (:func:`case_for_sensor`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..model.measurement import SensorModel
from ..model.sea import Sea
from ..model.sensors import Sensor, sensor_model
from .motion import straight_track

__all__ = ["CASES", "MAGNETIC_MOMENT", "TrackCase", "case_for_sensor", "resolve_case"]


@dataclass(frozen=True)
class TrackCase:
    """A tracking scenario: sensors, medium, true track, filter model and priors.

    Lengths in m (z = depth), angles in rad (our frame), moments in A·m, noise in V/m (electric;
    with ``sensor=`` the noise, medium and units are the Sensor's: nT, nT/m, A·m²).
    """

    name: str
    stations: tuple
    axes: int
    start: tuple
    heading: float
    speed: float = 2.0
    steps: int = 300
    T: float = 1.0
    Ph: float = 100.0
    Pv: float = 0.0
    noise: float = 1e-7
    sigma: float = 4.0
    sea_depth: float | None = None
    seabed_sigma: float | None = None
    sigma_a: float = 0.1
    alpha: float = 0.001
    #: Prior σ of the EKF/PUEKF start (x, y, z, vx, vy, Ph, Pv).
    prior_std: tuple = (20.0, 20.0, 0.5, 0.5, 0.5, 20.0, 5.0)
    #: Hypothesised source depth of the bank (m), its σ ξ_z (m) and the σ of Pv (A·m).
    bank_depth: float = 0.2
    bank_depth_std: float = 1.0
    bank_pv_std: float = 10.0
    description: str = field(default="", compare=False)
    #: The measurement model (a core.Sensor or a kind name); None: the electric one of
    #: ``noise``, ``sigma``, ``sea_depth``, ``seabed_sigma``.
    sensor: object = None
    #: The moment entries of the true state instead of (Ph, Pv): (mx, my, mz) in A·m² for a
    #: magnetic sensor.
    moments: tuple | None = None
    #: The bank's strength levels (A·m electric, A·m² magnetic); None: seed 001's
    #: :data:`core.BANK_STRENGTHS`.
    bank_strengths: tuple | None = None

    def sensors(self):
        """The :class:`core.SensorModel` of the case (a :class:`core.Sea` where it has one)."""
        stations = np.array(self.stations, float)
        if self.sensor is not None:
            return SensorModel(stations, axes=self.axes, sensor=self.sensor)
        sea = None if self.sea_depth is None else Sea(self.sea_depth, self.seabed_sigma)
        return SensorModel(stations, axes=self.axes, noise=self.noise, sigma=self.sigma, sea=sea)

    def nominal_track(self):
        """The straight true track, (steps, n): n = 7 electric, 8 with magnetic ``moments``."""
        if self.moments is not None:
            return straight_track(self.start, self.heading, self.speed, self.steps, T=self.T,
                                  moments=self.moments)
        return straight_track(self.start, self.heading, self.speed, self.steps, T=self.T,
                              Ph=self.Ph, Pv=self.Pv)

    def prior_cov(self):
        """Prior covariance of the EKF / PUEKF start (n, n)."""
        return np.diag(np.asarray(self.prior_std, float) ** 2)

    def bank_prior_info(self):
        """What every bank hypothesis knows a priori, as information (n, n): the depth (ξ_z)
        and, electric, Pv; flat in x, y, velocity and the strength (what the hypotheses guess;
        a magnetic hypothesis guesses every moment component)."""
        sensors = self.sensors()
        n = sensors.n_states
        info = np.zeros((n, n))
        info[2, 2] = 1.0 / self.bank_depth_std**2
        _, std = sensors.sensor.bank_moments(np.inf, 1.0, self.bank_pv_std)  # guessed: σ = ∞
        info[np.arange(5, n), np.arange(5, n)] = 1.0 / std**2
        return info

    def check(self):
        """ValueError unless the track, the prior and the sensor have one state size."""
        n = self.sensors().n_states
        n_track = self.nominal_track().shape[-1]
        if n_track != n:
            raise ValueError(
                f"case {self.name!r}: sensor kind {self.sensors().kind!r} has {n} states but the "
                f"track has {n_track}: give moments=(mx, my, mz) (A·m²) for a magnetic sensor"
            )
        if len(self.prior_std) != n:
            raise ValueError(f"case {self.name!r}: prior_std must have {n} entries (one per "
                             f"state); got {len(self.prior_std)}")


_SEED_GEOMETRY = dict(
    stations=((0.0, -5.0, 8.4), (0.0, 5.0, 8.4)),
    start=(-57.1, 280.0, 0.2),
    heading=-np.pi / 2,
)

#: The two cases of seed 001 (see the module notes).
CASES = {
    "seed001-sim": TrackCase(
        name="seed001-sim", axes=3, **_SEED_GEOMETRY,
        description="seed 001 simulation: whole space, two 3-axis sensors, p = 100 A·m",
    ),
    "seed001-trial": TrackCase(
        name="seed001-trial", axes=2, sea_depth=8.4, seabed_sigma=0.4, **_SEED_GEOMETRY,
        prior_std=(20.0, 20.0, 0.1, 0.5, 0.5, 20.0, 5.0), bank_depth_std=0.2,
        description="seed 001 sea-trial geometry: D = 8.4 m, σb = 0.4 S/m, two 2-axis seabed sensors",
    ),
}


#: The magnetic target of :func:`case_for_sensor` (A·m²): |m| ≈ 1e5 A·m², a submarine's order
#: of magnitude, mostly vertical (induced under a steep geomagnetic field) with a horizontal
#: permanent part. At seed 001's start (≈ 285 m) B ≈ 0.4–0.9 nT (40–90 σ at 0.01 nT) while G
#: (≈ 3B/r ≈ 0.005 nT/m) is below its 0.01 nT/m noise until the target comes within ~100 m.
MAGNETIC_MOMENT = (3.0e4, 2.0e4, 9.0e4)


def case_for_sensor(case, sensor):
    """Seed 001's case (a name or a :class:`TrackCase`) measured by another sensor kind.

    ``"E"`` (or None) returns the case. A magnetic kind (a name or a :class:`core.Sensor`) keeps
    the geometry, track and filter model and changes what the target and the sensors are: the
    target carries :data:`MAGNETIC_MOMENT` (A·m²), the stations report every component of the
    kind (3 axes; a magnetostatic field does not see the layered sea), the prior σ of the
    moment is 30 % of |m| per component, and the bank's strength levels are |m| × (½, 1, 2)
    (seed 001's 50 / 100 / 200 around the truth).
    """
    case = resolve_case(case)
    sensor = sensor_model(sensor)
    if sensor.kind == "E":
        return case if sensor == Sensor("E") else dataclasses.replace(case, sensor=sensor)
    m = float(np.linalg.norm(MAGNETIC_MOMENT))
    return dataclasses.replace(
        case, name=f"{case.name}-{sensor.kind}", sensor=sensor, axes=3, moments=MAGNETIC_MOMENT,
        prior_std=tuple(case.prior_std[:5]) + (0.3 * m,) * 3,
        bank_strengths=(0.5 * m, m, 2.0 * m),
        description=f"{case.description}; sensor {sensor.kind}, moment {MAGNETIC_MOMENT} A·m²")


def resolve_case(case):
    """The :class:`TrackCase` of a case name (or the case itself); ValueError otherwise."""
    if isinstance(case, TrackCase):
        return case
    if case not in CASES:
        raise ValueError(f"case must be one of {list(CASES)} or a TrackCase; got {case!r}")
    return CASES[case]
