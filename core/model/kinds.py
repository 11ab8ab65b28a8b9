"""What differs between sensor kinds, written once: each kind's row of :data:`SPECS` is its
measurement family, to which :class:`core.model.sensors.Sensor` hands every kind-dependent step
(the states, the measurement and its kernel rows, the checks on a target's distance, the filter
bank's moments). A new kind adds a rows code to the kernels (core.kernels.gamma), a row here,
and its description in :data:`core.model.sensors.KINDS`.
"""

from __future__ import annotations

import numpy as np

from ..kernels.electric import N_STATES as ELECTRIC_STATES
from ..kernels.magnetic import N_STATE as MAGNETIC_STATES
from . import magnetic as mg
from . import validation
from . import sea as sea_module
from .fields import MODELS, field_jacobian


class Electric:
    """The electric kind: a dipole's field in the sea, 7 states ``[x, y, z, vx, vy, Ph, Pv]``."""

    magnetic = False
    n_states = ELECTRIC_STATES
    state_names = validation.STATE_NAMES

    def check(self, sensor):
        """Nothing more than the Sensor's own checks."""

    def states(self, value):
        return validation.states(value)

    def measure(self, sensor, states, stations):
        """h and its Jacobian from :func:`core.field_jacobian` (the field is linear in (Ph, Pv)
        at fixed position and heading, in any linear medium)."""
        states = np.asarray(states, dtype=float)
        kw = dict(sigma=sensor.sigma, model=sensor.model)
        if sensor.sea is not None:  # only when given: the whole-space core needs no sea argument
            kw["sea"] = sensor.sea
        J = field_jacobian(states, stations, **kw)  # (..., S, 3, 7)
        h = J[..., 5] * states[..., None, None, 5] + J[..., 6] * states[..., None, None, 6]
        return h, J

    def kernel_rows(self, sensor, whiten):
        """κ = 1/(4πσ), the field model's code, the medium; one noise, applied outside."""
        code = validation.model_code(sensor.model, MODELS)
        return (1.0 / (4.0 * np.pi * sensor.sigma), code, sea_module.medium(sensor.sea, sensor.sigma)), \
            sensor.noise_vector[0]

    def check_column(self, sensor, states, stations):
        sea_module.check_column(sensor.sea, states, stations, sensor.model)

    def check_clear(self, sensor, states, stations, steps, T):
        """At the first instant (the kernels give NaN later)."""
        validation.no_target_on_station(states, stations)

    def clear_instants(self, steps):
        """The instants of Γ at which a target must be clear of the stations: the first."""
        return 1

    def bank_moments(self, p, strength_frac, pv_std):
        """(Ph, Pv) = (p, 0), σ = (strength_frac·p, pv_std): seed 001's horizontal dipole."""
        mean = np.concatenate([p, np.zeros_like(p)], axis=-1)
        return mean, np.concatenate([strength_frac * p, np.full_like(p, pv_std)], axis=-1)

    def refuse_square(self, sensor, what):
        """The paper's square-Γ rule is the electric kind's own."""


class Magnetic:
    """A magnetic kind (B, G, BG): a magnetic dipole's field or tensor, 8 states
    ``[x, y, z, vx, vy, mx, my, mz]``; a static field does not see the sea."""

    magnetic = True
    n_states = MAGNETIC_STATES
    state_names = mg.MAGNETIC_STATE_NAMES

    def check(self, sensor):
        if sensor.sea is not None or sensor.model != "exact":
            raise ValueError(
                f"sensor kind {sensor.kind!r} is magnetic: a static magnetic field does not see the "
                "sea (μr ≈ 1), and the 'paper' model is the electric paper's; leave sea=None and "
                "model='exact'"
            )

    def states(self, value):
        return mg.states(value)

    def measure(self, sensor, states, stations):
        """:func:`core.magnetic_jacobian`."""
        return mg.magnetic_jacobian(states, stations, sensor=sensor.kind, baseline=sensor.baseline)

    def kernel_rows(self, sensor, whiten):
        """The kind's code and [near, baseline, 1/noise_B, 1/noise_G]: rows come whitened (B in
        nT and G in nT/m made commensurate), the noise outside is 1."""
        noise = sensor.noise_vector
        wb, wg = (1.0 / noise[0], 1.0 / noise[-1]) if whiten else (1.0, 1.0)
        params = np.array([sensor.near, mg.baseline_value(sensor.baseline), wb, wg])
        return (0.0, mg.MAGNETIC_CODES[sensor.kind], params), 1.0

    def check_column(self, sensor, states, stations):
        """A magnetostatic field does not see the sea: nothing to check."""

    def check_clear(self, sensor, states, stations, steps, T):
        """Within :attr:`Sensor.near` at any of the ``steps`` instants."""
        baseline = mg.baseline_value(sensor.baseline) if "G" in sensor.kind else 0.0
        for i in range(1 if steps is None else steps):
            moved = states.copy()
            moved[:, :2] += i * T * states[:, 3:5]
            mg.check_distances(moved, stations, baseline)

    def clear_instants(self, steps):
        """Every instant of Γ."""
        return validation.steps(steps, 1)

    def bank_moments(self, p, strength_frac, pv_std):
        """(mx, my, mz) = (0, 0, p), σ = strength_frac·p on each component."""
        mean = np.concatenate([np.zeros(p.shape[:-1] + (2,)), p], axis=-1)
        return mean, np.repeat(strength_frac * p, 3, axis=-1)

    def refuse_square(self, sensor, what):
        raise ValueError(
            f"{what} uses the paper's square-Γ rule, which is the electric paper's (its row order "
            f"and its 7 states); sensor kind {sensor.kind!r} needs the all-rows Γ: pass steps=N "
            "(or a Fisher / CRLB measure)"
        )


_ELECTRIC, _MAGNETIC = Electric(), Magnetic()
#: Each sensor kind's measurement family: the one table of what differs between kinds.
SPECS = {"E": _ELECTRIC, "B": _MAGNETIC, "G": _MAGNETIC, "BG": _MAGNETIC}
