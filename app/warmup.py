"""Compile every numba kernel the dashboard uses, once, before the first visitor.

On a fresh checkout (or a fresh container layer) numba compiles the kernels on first use, ~3 min
of LLVM; the first page would wait for it. ``python -m app.warmup`` does it ahead of time (the
Dockerfile runs it at build time), and ``app/server_lifecycle.py`` runs it when ``panel serve app``
loads, before the server takes its first session. With the on-disk cache already filled it takes
about a second.
"""

from __future__ import annotations

import time

import core
from core.pcrlb import pcrlb


def compile_kernels():
    """Run each kernel family once on a tiny input: whole space and layered sea, both field models,
    every map measure, the CRLB maps and the bound along a track. Returns the seconds taken."""
    t0 = time.perf_counter()
    plane = core.Plane("xy", (-10, 10), (-10, 10), 120.0, 3)
    stations = core.dual_station(100, 15)
    for model in core.MODELS:
        for measure in core.MEASURES:
            core.evaluate_map(plane, stations, velocity=(2, 2), moments=(100, 20),
                              measure=measure, model=model)
    sea = core.Sea(200.0, 1.0)
    for measure in core.MEASURES:
        core.evaluate_map(plane, stations, velocity=(2, 2), moments=(100, 20), measure=measure,
                          sea=sea)
    state = [30, 40, 120, 2, 2, 100, 20]
    core.gamma(state, [[0, 0, 100]])
    core.dipole_field(state, [[0, 0, 100]], sea=sea)
    core.crlb_maps(plane, stations, velocity=(2, 2), moments=(100, 20))
    core.crlb_maps(plane, stations, velocity=(2, 2), moments=(100, 20), sea=sea)
    track = [[30.0 + 2 * k, 40.0, 120.0, 2.0, 0.0, 100.0, 20.0] for k in range(3)]
    pcrlb(track, core.SensorModel(stations))
    return time.perf_counter() - t0


if __name__ == "__main__":
    print(f"numba kernels ready in {compile_kernels():.1f} s")
