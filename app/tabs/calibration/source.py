"""A calibration data source that comes with its own conditions brings them (issue 46, defect 3).

Seed 004's Table 1 was recorded under a known geomagnetic field and reading noise. Chosen in the
*Calibration data* list (or given alone in a link), it was solved with whatever Be and noise the
inputs held, the simulation's: Bp3 came out 3077 nT against 2597 nT from its preset and from
``python -m core.calibration data/seed004_table1.csv --be 34425,1961,35898``, and nothing said
that Be was not the table's. Now choosing the source sets its Be and noise, as its preset does,
and says so; a value given with it (a preset, a link that names it) is kept.
"""

from __future__ import annotations

from .calibration import BE, PRESETS

#: Per data source, the inputs it brings: Table 1's Be (nT) and its errors (its preset's).
OWN = {"Seed 004 Table 1": {n: PRESETS["Seed 004 Table 1"][n]
                            for n in (*BE, "cal_noise_nt", "cal_angle_noise_deg")}}
#: The inputs any source brings.
BROUGHT = sorted({n for own in OWN.values() for n in own})


def said(source, values):
    """What the page says when ``source`` set ``values``."""
    be = ", ".join(f"{values[n]:g}" for n in BE if n in values)
    noise = values.get("cal_noise_nt")
    return (f"{source} brings its own conditions: set " + ", ".join(
        [f"Be = [{be}] nT"] * bool(be)
        + [f"reading error ± {noise:.4g} nT"] * (noise is not None)
        + [f"angle error ± {values['cal_angle_noise_deg']:g}°"] * ("cal_angle_noise_deg" in values))
        + " (its preset's).")


def bring_own_values(scenario):
    """Watch ``scenario``'s calibration source: a source of :data:`OWN` chosen on its own sets
    the inputs it brings that were not set with it, and says so next to the tab's inputs."""
    def chosen(*events):
        given = {e.name for e in events}
        source = scenario.value("cal_source")
        if "cal_source" not in given or source not in OWN:
            return
        values = {n: v for n, v in OWN[source].items()
                  if n not in given and scenario.value(n) != v}
        if values:
            scenario.update(values)
            scenario.param.update(message=said(source, values), refused=["cal_source"])

    scenario.watch_inputs(chosen, ["cal_source", *BROUGHT])
