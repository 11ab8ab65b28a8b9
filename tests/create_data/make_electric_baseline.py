"""Make tests/data/electric_baseline.npz: the electric results of the core before issue 26.

Issue 26 rebuilt the core around one measurement model (sensor kinds, magnetic physics, a
package layout); the electric results must not move. This script evaluates a fixed set of
cases through public names only (Γ, its measures and rank, Fisher, CRLB, maps, CRLB maps, in the
whole space and a layered sea, both field models). The committed data were made from commit
47b19e9 (the last before the change), where every function took the medium as ``sigma=``,
``model=``, ``sea=``; the cases now describe it as the ``core.Sensor`` those keywords build (the
spec's Γ functions and the fields keep the keywords), so the script runs on the code since issue
36 (on older code, use its version at 47b19e9). tests/test_electric_baseline.py compares the core
with the data. Run from the repository root:

    python -m tests.create_data.make_electric_baseline [OUT.npz]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import core

OUT = Path(__file__).resolve().parents[1] / "data" / "electric_baseline.npz"

RNG_SEED = 20261202
SINGLE = [[0.0, 0.0, 100.0]]
DUAL = [[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]]
TRIPLE = [[0.0, 0.0, 100.0], [40.0, 10.0, 100.0], [-20.0, 35.0, 95.0]]
SEA = dict(depth=200.0, seabed_sigma=1.0)


def random_states(n, rng):
    """Targets in the paper's region: x, y ∈ [−300, 300], z ∈ [105, 190] (inside SEA's water)."""
    return np.column_stack([
        rng.uniform(-300, 300, n), rng.uniform(-300, 300, n), rng.uniform(105, 190, n),
        rng.uniform(-3, 3, n), rng.uniform(0.5, 3, n), rng.uniform(20, 150, n),
        rng.uniform(-50, 50, n),
    ])


def cases():
    """(name, function) pairs; every function returns one ndarray."""
    rng = np.random.default_rng(RNG_SEED)
    states = random_states(40, rng)
    out = []
    media = {"free": {}, "sea": {"sea": core.Sea(**SEA)}, "sigma1": {"sigma": 1.0}}
    for mname, medium in media.items():
        for sname, stations in (("single", SINGLE), ("dual", DUAL), ("triple", TRIPLE)):
            kw = dict(medium)
            sensor = core.Sensor("E", **medium)
            key = f"{mname}_{sname}"
            out += [
                (f"field_{key}", lambda kw=kw, st=stations: core.dipole_field(states, st, **kw)),
                (f"jac_{key}", lambda kw=kw, st=stations: core.field_jacobian(states, st, **kw)),
                (f"gamma_{key}", lambda kw=kw, st=stations: core.gamma(states, st, **kw)),
                (f"gamma3_{key}", lambda kw=kw, st=stations: core.gamma(states, st, steps=3, **kw)),
                (f"logdet_{key}", lambda kw=kw, st=stations: core.log10_abs_det_gamma(states, st, **kw)),
                (f"eta_{key}", lambda s=sensor, st=stations: core.observability_index(states, st, sensor=s)),
                (f"rank_{key}", lambda kw=kw, st=stations: core.observable_rank(states, st, **kw)),
                (f"rank3_{key}", lambda kw=kw, st=stations: core.observable_rank(states, st, steps=3, **kw)),
                (f"fisher_{key}", lambda s=sensor, st=stations: core.fisher_information(states, st, sensor=s)),
                (f"crlbcov_{key}", lambda s=sensor, st=stations: core.crlb_covariance(states, st, sensor=s)[0]),
            ]
            for field in ("d_optimal", "position_std", "log10_eta", "observable"):
                out.append((f"fm_{field}_{key}", lambda s=sensor, st=stations, f=field: np.asarray(
                    getattr(core.fisher_measures(states, st, sensor=s), f))))
    # the paper model (whole space only)
    for sname, stations in (("single", SINGLE), ("dual", DUAL)):
        out += [
            (f"field_paper_{sname}", lambda st=stations: core.dipole_field(states, st, model="paper")),
            (f"gamma_paper_{sname}", lambda st=stations: core.gamma(states, st, model="paper")),
            (f"logdet_paper_{sname}", lambda st=stations: core.log10_abs_det_gamma(states, st, model="paper")),
            (f"crlbcov_paper_{sname}", lambda st=stations: core.crlb_covariance(
                states, st, sensor=core.Sensor("E", model="paper"))[0]),
        ]
    # maps and CRLB maps (x–y plane at the paper's depth; x–z plane)
    planes = {"xy": core.Plane("xy", (-300, 300), (-300, 300), 120.0, 23),
              "xz": core.Plane("xz", (-300, 300), (105, 190), 50.0, 17)}
    for pname, plane in planes.items():
        for mname, medium in (("free", {}), ("sea", {"sea": core.Sea(**SEA)})):
            for measure in ("log10_det", "log10_eta", "d_optimal", "crlb_position"):
                key = f"map_{measure}_{pname}_{mname}"
                out.append((key, lambda p=plane, m=measure, kw=medium: core.evaluate_map(
                    p, DUAL, velocity=(2, 2), moments=(100, 20), measure=m,
                    sensor=core.Sensor("E", **kw)).value))
                out.append((key + "_obs", lambda p=plane, m=measure, kw=medium: core.evaluate_map(
                    p, SINGLE, velocity=(2, 2), moments=(100, 20), measure=m,
                    sensor=core.Sensor("E", **kw)).observable))
            for field in ("semi_major", "semi_minor", "orientation", "sigma_z", "sigma_speed",
                          "position", "observable"):
                out.append((f"crlbmap_{field}_{pname}_{mname}", lambda p=plane, f=field, kw=medium:
                            getattr(core.crlb_maps(p, DUAL, velocity=(2, -1), moments=(80, 30),
                                                   sensor=core.Sensor("E", **kw)), f)))
    # a layout criterion (design)
    region = core.Plane("xy", (-200, 200), (-200, 200), 120.0, 9)
    out.append(("layout_criterion", lambda: np.asarray(core.layout_criterion(
        DUAL, region).value, dtype=float)))
    return out


def main(path=OUT):
    data = {name: np.asarray(f()) for name, f in cases()}
    np.savez_compressed(path, **data)
    print(f"wrote {len(data)} arrays to {path}")


if __name__ == "__main__":
    main(*sys.argv[1:])
