"""The sensor kinds of the scenario's *Sensor* selector, one small param part each: its label
(what the selector offers, and what a link writes), its core kind, and the ``core.Sensor`` it
builds from a scenario's values (spec §11).

The selector (``app.state.parts.Sensor.sensor``) chooses among :data:`KINDS` by label; what each kind
reads is declared on the inputs (their ``kinds``, app.state.part), and tests/test_sensor_parts.py
checks that each part reads exactly those. A new sensor kind is a part here (and its inputs
declared with its kind in app/state/parts.py).

No Panel import.
"""

from __future__ import annotations

import param

import core

#: The electric field formulas: label -> core.Sensor model.
MODELS = {"exact dipole": "exact", "paper eqs. (10)–(12) as printed": "paper"}


class SensorKind(param.Parameterized):
    """One sensor kind: what every station measures, and the ``core.Sensor`` that measures it
    for a scenario's values ``v`` (a :class:`app.state.scenario.ScenarioValues`, or any object with
    the inputs as attributes)."""

    label = param.String(constant=True, doc="The Sensor selector's label (written in links).")
    words = param.String(constant=True, doc="The kind in titles and captions.")
    unit = param.String(constant=True, doc="The unit of its readings.")
    kind = param.Selector(objects=list(core.KINDS), constant=True, doc="The core kind.")

    def sensor(self, v):
        """The ``core.Sensor`` of this kind for values ``v``."""
        raise NotImplementedError

    def noise_text(self, v):
        """The sensor noise of values ``v`` with its unit, as the page says it."""
        raise NotImplementedError


class Electric(SensorKind):
    """The electric field (the paper): its noise in V/m, the sea's conductivity, a layered sea
    (spec §7) and the field formula."""

    def __init__(self, **params):
        super().__init__(label="electric (E, V/m)", kind="E", words="electric", unit="V/m", **params)

    def sensor(self, v):
        sea = core.Sea(v.sea_depth, v.seabed_sigma) if v.sea_model == "layered" else None
        return core.Sensor("E", v.noise, v.sigma, sea, MODELS[v.model])

    def noise_text(self, v):
        return f"{v.noise:g} V/m"


def _baseline(v):
    """A gradiometer's baseline (m), or None for the point gradient tensor (0)."""
    return v.baseline if v.baseline > 0 else None


class Magnetometer(SensorKind):
    """The magnetic field, B (nT): a static field does not see the sea."""

    def __init__(self, **params):
        super().__init__(label="magnetometer (B, nT)", kind="B", words="magnetometer", unit="nT",
                         **params)

    def sensor(self, v):
        return core.Sensor("B", v.noise_b, baseline=None)

    def noise_text(self, v):
        return f"{v.noise_b:g} nT"


class Gradiometer(SensorKind):
    """The magnetic gradient tensor, G (nT/m), at a point or over a baseline."""

    def __init__(self, **params):
        super().__init__(label="gradiometer (G, nT/m)", kind="G", words="gradiometer", unit="nT/m",
                         **params)

    def sensor(self, v):
        return core.Sensor("G", v.noise_g, baseline=_baseline(v))

    def noise_text(self, v):
        return f"{v.noise_g:g} nT/m"


class MagnetometerGradiometer(SensorKind):
    """Both magnetic kinds at every station, BG (nT and nT/m)."""

    def __init__(self, **params):
        super().__init__(label="magnetometer + gradiometer (BG)", kind="BG",
                         words="magnetometer + gradiometer", unit="nT, nT/m", **params)

    def sensor(self, v):
        return core.Sensor("BG", (v.noise_b, v.noise_g), baseline=_baseline(v))

    def noise_text(self, v):
        return f"{v.noise_b:g} nT and {v.noise_g:g} nT/m"


#: The sensor parts, in the selector's order.
KINDS = (Electric(), Magnetometer(), Gradiometer(), MagnetometerGradiometer())
#: Each part by its label (the selector's value) and by its core kind.
BY_LABEL = {part.label: part for part in KINDS}
BY_KIND = {part.kind: part for part in KINDS}
