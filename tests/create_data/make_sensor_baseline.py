"""Make tests/data/sensor_baseline.npz: every sensor kind's results before one engine (issue 36).

Issue 36 runs every sensor kind (E in the whole space and a layered sea, B, G, BG, two
gradiometers a baseline apart) through one compiled pipeline; its results must not move: the
magnetic ones to 1e-10 relative, the electric ones to 1e-12, ill-conditioned points to their
condition number's error bound (tests/test_sensor_baseline.py says how). This script evaluates
every measure through public names only, with the measurement described once as a
``core.Sensor`` (the form both the code before and after accept): the measurement h and its
Jacobian, Γ (all rows of three instants; the paper's square Γ for the electric kind), log10|det Γ|,
the observability index, the rank verdict, Fisher, the Fisher measures (D-optimal, η, CRLB
standard deviations, the verdict), the CRLB covariance and its horizontal ellipse, at seeded
random points; maps of every measure the kind has (value and verdict, with the station mask:
each plane passes through a station) and CRLB maps on small grids, with the Fisher matrix (and
the electric square Γ) at every map point, from which the test takes the condition numbers; the
layout criteria. The committed data were made from commit ecd374c (the last before the change)
in a throwaway worktree, with its own numba cache. Run from the repository root:

    python -m tests.create_data.make_sensor_baseline [OUT.npz]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import core

OUT = Path(__file__).resolve().parents[1] / "data" / "sensor_baseline.npz"

RNG_SEED = 20261204
SEA = core.Sea(depth=200.0, seabed_sigma=1.0)
#: Electric geometry (the paper's): stations at 100 m depth, targets 5–90 m below them.
E_STATIONS = {"single": [[0.0, 0.0, 100.0]],
              "dual": [[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]],
              "triple": [[0.0, 0.0, 100.0], [40.0, 10.0, 100.0], [-20.0, 35.0, 95.0]]}
#: Magnetic geometry (seed 003's scale): stations at the origin, targets 5–60 m away.
M_STATIONS = {"single": [[0.0, 0.0, 0.0]], "dual": [[0.0, 0.0, 0.0], [6.0, 0.0, 0.0]]}
#: Sensor name -> (core.Sensor, stations, electric?). "Gb": two gradiometers (and one) with a
#: 0.5 m baseline, seed 003's array.
SENSORS = {
    "Efree": (core.Sensor("E"), E_STATIONS, True),
    "Esea": (core.Sensor("E", sea=SEA), E_STATIONS, True),
    "B": (core.Sensor("B"), M_STATIONS, False),
    "G": (core.Sensor("G"), M_STATIONS, False),
    "BG": (core.Sensor("BG", noise=(0.1, 0.01)), M_STATIONS, False),
    "Gb": (core.Sensor("G", baseline=0.5), M_STATIONS, False),
}
E_PLANES = {"xy": core.Plane("xy", (-300, 300), (-300, 300), 100.0, 15),  # through (0, 0, 100)
            "xz": core.Plane("xz", (-300, 300), (60, 190), 0.0, 13)}
M_PLANES = {"xy": core.Plane("xy", (-60, 60), (-60, 60), 0.0, 15),  # through (0, 0, 0)
            "xz": core.Plane("xz", (-60, 60), (-40, 40), 3.0, 13)}
E_TARGET = dict(velocity=(2.0, 2.0), moments=(100.0, 20.0))
M_TARGET = dict(velocity=(2.0, 1.0), moments=(30.0, -50.0, 80.0))
#: Regions of the layout criteria (electric, magnetic).
REGIONS = {True: core.Plane("xy", (-200, 200), (-200, 200), 120.0, 7),
           False: core.Plane("xy", (-40, 40), (-40, 40), 10.0, 7)}


def electric_states(n, rng):
    """x, y ∈ [−300, 300], z ∈ [105, 190] (inside SEA's water), speeds and moments of the paper."""
    return np.column_stack([
        rng.uniform(-300, 300, n), rng.uniform(-300, 300, n), rng.uniform(105, 190, n),
        rng.uniform(-3, 3, n), rng.uniform(0.5, 3, n), rng.uniform(20, 150, n),
        rng.uniform(-50, 50, n),
    ])


def magnetic_states(n, rng):
    """x, y ∈ [−60, 60], z ∈ [5, 60] (≥ 5 m from the stations at every instant), velocities up
    to 3 m/s, moments of random direction and 1 … 1e4 A·m²."""
    mom = rng.normal(size=(n, 3)) * 10 ** rng.uniform(0, 4, (n, 1))
    return np.column_stack([rng.uniform(-60, 60, n), rng.uniform(-60, 60, n),
                            rng.uniform(5, 60, n), rng.uniform(-3, 3, (n, 2)), mom])


def point_cases(key, sensor, states, stations, electric):
    """(name, function) of every per-point result of one sensor at one station set."""
    kw = dict(sensor=sensor)
    out = [
        (f"h_{key}", lambda: sensor.measure(states, stations)[0]),
        (f"H_{key}", lambda: sensor.measure(states, stations)[1]),
        (f"gamma3_{key}", lambda: core.gamma(states, stations, steps=3, **kw)),
        (f"eta3_{key}", lambda: core.observability_index(states, stations, steps=3, **kw)),
        (f"rank3_{key}", lambda: core.observable_rank(states, stations, steps=3, **kw)),
        (f"fisher_{key}", lambda: core.fisher_information(states, stations, **kw)),
        (f"crlbcov_{key}", lambda: core.crlb_covariance(states, stations, **kw)[0]),
        (f"crlbobs_{key}", lambda: core.crlb_covariance(states, stations, **kw)[1]),
    ]
    if electric:  # the paper's square Γ and its measures
        out += [
            (f"gammasq_{key}", lambda: core.gamma(states, stations, **kw)),
            (f"logdet_{key}", lambda: core.log10_abs_det_gamma(states, stations, **kw)),
            (f"etasq_{key}", lambda: core.observability_index(states, stations, **kw)),
            (f"ranksq_{key}", lambda: core.observable_rank(states, stations, **kw)),
        ]
    for field in ("d_optimal", "log10_eta", "observable", "std", "position_std"):
        out.append((f"fm_{field}_{key}", lambda f=field: getattr(
            core.fisher_measures(states, stations, **kw), f)))
    for field in ("semi_major", "semi_minor", "orientation", "sigma_z", "sigma_speed",
                  "position", "observable"):
        out.append((f"ell_{field}_{key}", lambda f=field: getattr(
            core.horizontal_error_ellipse(states, stations, **kw), f)))
    return out


def map_cases(key, sensor, plane, stations, target, electric):
    """Maps of every measure the kind has, CRLB maps, and the Fisher matrix (electric: and the
    square Γ) at every map point (NaN on the station mask)."""
    measures = list(core.MEASURES) if electric else ["d_optimal", "crlb_position"]
    out = []
    for m in measures:
        out.append((f"map_{m}_{key}", lambda m=m: core.evaluate_map(
            plane, stations, measure=m, sensor=sensor, **target).value))
        out.append((f"mapobs_{m}_{key}", lambda m=m: core.evaluate_map(
            plane, stations, measure=m, sensor=sensor, **target).observable))
    for field in ("semi_major", "semi_minor", "orientation", "sigma_z", "sigma_speed",
                  "position", "observable"):
        out.append((f"crlbmap_{field}_{key}", lambda f=field: getattr(
            core.crlb_maps(plane, stations, sensor=sensor, **target), f)))

    def at_points(f, shape):
        states = plane.states(target["velocity"], target["moments"])
        on = np.isnan(core.evaluate_map(plane, stations, measure="d_optimal", sensor=sensor,
                                        **target).value)
        res = np.full(states.shape[:2] + shape, np.nan)
        res[~on] = f(states[~on])
        return res

    n = sensor.n_states
    out.append((f"mapfisher_{key}", lambda: at_points(
        lambda s: core.fisher_information(s, stations, sensor=sensor), (n, n))))
    if electric:
        out.append((f"mapgammasq_{key}", lambda: at_points(
            lambda s: core.gamma(s, stations, sensor=sensor), (7, 7))))
    return out


def cases():
    """(name, function) pairs; every function returns one array. Names end in
    ``_<sensor>_<stations>`` (points, criteria) or ``_<sensor>_<plane>`` (maps)."""
    rng = np.random.default_rng(RNG_SEED)
    states = {True: electric_states(40, rng), False: magnetic_states(40, rng)}
    out = []
    for sname, (sensor, station_sets, electric) in SENSORS.items():
        for stname, stations in station_sets.items():
            out += point_cases(f"{sname}_{stname}", sensor, states[electric], stations, electric)
        planes, target = (E_PLANES, E_TARGET) if electric else (M_PLANES, M_TARGET)
        for pname, plane in planes.items():
            out += map_cases(f"{sname}_{pname}", sensor, plane, station_sets["dual"], target,
                             electric)
        region = REGIONS[electric]
        # the criteria of the baseline (the survey criteria of issue 49 are checked against
        # their maps in tests/test_survey_design.py)
        for criterion in ("mean_dopt", "worst_dopt", "area_crlb"):
            out.append((f"criterion_{criterion}_{sname}_dual", lambda s=sensor, st=station_sets,
                        c=criterion, r=region, t=target: np.array(
                            [(res := core.layout_criterion(st["dual"], r, criterion=c, sensor=s,
                                                           **t)).value,
                             res.observable_fraction])))
    return out


def main(path=OUT):
    data = {name: np.asarray(f()) for name, f in cases()}
    np.savez_compressed(path, **data)
    print(f"wrote {len(data)} arrays to {path}")


if __name__ == "__main__":
    main(*sys.argv[1:])
