"""Benchmark of the layered sea (issue 17: a 400 × 400 dual-station log10|det Γ| map in a
layered sea should cost ≤ 8× the whole-space map).

    python -m bench.bench_sea [--repeat 5] [--n 400] [--empymod-points 20]

For each sea — (D = 200 m, σb = 1 S/m) and (D = 130 m, σb = 0.1 S/m), σ = 4 S/m — in the same
run: the median time of the whole-space map and of the layered map, their ratio; the 200 × 200
pair of maps a dashboard slider release computes (one station and two, issue 17: ≤ 300 ms);
the free-space images the series evaluates per target–station pair (mean, max; tail nodes
included; each pair alone, and in the map kernels' lockstep of LANES points), and
empymod's time per field evaluation at sampled map points, extrapolated to the map's field
evaluations. Geometry: the paper's dual layout (stations at depth 100 m, d = 15 m), targets at
depth 120 m over x, y ∈ [−300, 300] m, v = (2, 2) m/s, (Ph, Pv) = (100, 20) A·m.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numba
import numpy as np

import core
from core.kernels.gamma import LANES
from core.model.sea import image_counts

STATIONS = core.dual_station(100, 15)
VELOCITY, MOMENTS = (2.0, 2.0), (100.0, 20.0)
SEAS = (core.Sea(200.0, 1.0), core.Sea(130.0, 0.1))
SIGMA = 4.0


def interleaved_medians(fns, repeat):
    """Median wall time of each function, runs interleaved so that both see the same load."""
    for fn in fns:
        fn()  # warm-up (compilation, caches)
    times = [[] for _ in fns]
    for _ in range(repeat):
        for fn, t in zip(fns, times):
            t0 = time.perf_counter()
            fn()
            t.append(time.perf_counter() - t0)
    return [statistics.median(t) for t in times]


def empymod_seconds_per_field(sea, states, stations):
    """Median wall time of one 3-component field from empymod (three source directions give
    the tensor; one call per receiver component and source direction, as the spec's recipe)."""
    import empymod

    res = [2e14, 1 / SIGMA, 1 / sea.seabed_sigma]
    times = []
    for x in states:
        for st in stations:
            t0 = time.perf_counter()
            for ab in (11, 21, 31, 13, 23, 33):  # Ph along x, and Pv
                empymod.dipole(src=list(x[:3]), rec=list(st), depth=[0, sea.depth], res=res,
                               freqtime=1e-20, ab=ab, verb=0)
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--n", type=int, default=400)
    ap.add_argument("--empymod-points", type=int, default=20)
    args = ap.parse_args(argv)
    plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, args.n)
    states = plane.states(VELOCITY, MOMENTS).reshape(-1, 7)
    print(f"machine: {os.cpu_count()} CPUs, {numba.config.NUMBA_NUM_THREADS} numba threads, "
          f"numba {numba.__version__}; grid {args.n} x {args.n}, dual stations d = 15 m at 100 m, "
          f"targets at 120 m; median of {args.repeat} (noisy shared machine)")

    def whole():
        return core.evaluate_map(plane, STATIONS, velocity=VELOCITY, moments=MOMENTS,
                                 sensor=core.Sensor("E", sigma=SIGMA))

    rng = np.random.default_rng(0)
    sample = states[rng.choice(states.shape[0], args.empymod_points, replace=False)]
    for sea in SEAS:
        def layered(sea=sea):
            return core.evaluate_map(plane, STATIONS, velocity=VELOCITY, moments=MOMENTS,
                                     sensor=core.Sensor("E", sigma=SIGMA, sea=sea))
        t_whole, t_sea = interleaved_medians((whole, layered), args.repeat)
        small = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 200)
        # a dashboard slider release draws two maps (A: one station, B: two) at 200 × 200
        t_small_whole, t_small = interleaved_medians([lambda s=s: [core.evaluate_map(
            small, st, velocity=VELOCITY, moments=MOMENTS,
            sensor=core.Sensor("E", sigma=SIGMA, sea=s))
            for st in (STATIONS[:1], STATIONS)] for s in (None, sea)], args.repeat)
        # images at instant 0 (the other two instants move the target by 2–4 m): each pair
        # summed alone, and as the map kernels sum them, LANES points in lockstep
        counts = image_counts(states, STATIONS, sea, sigma=SIGMA)
        lock = image_counts(states, STATIONS, sea, sigma=SIGMA, lanes=LANES)
        t_emp = empymod_seconds_per_field(sea, sample, STATIONS)
        n_fields = states.shape[0] * 3  # paper-rule dual Γ: 2 stations at k, station 1 at k+1
        print(f"\nsea D = {sea.depth:g} m, σb = {sea.seabed_sigma:g} S/m (η = {sea.eta(SIGMA):.3f})")
        print(f"  whole-space map      {1e3 * t_whole:9.1f} ms")
        print(f"  layered map          {1e3 * t_sea:9.1f} ms   ratio {t_sea / t_whole:5.1f}x")
        print(f"  200 x 200 A + B maps {1e3 * t_small:9.1f} ms (a dashboard slider release's core work; "
              f"whole space {1e3 * t_small_whole:.1f} ms)")
        print(f"  images per pair      mean {counts.mean():.1f}, max {counts.max()} (each pair alone); "
              f"mean {lock.mean():.1f}, max {lock.max()} (the map's {LANES} lanes in lockstep)")
        print(f"  empymod              {1e3 * t_emp:9.2f} ms per 3-component field; "
              f"{n_fields} fields -> ~{t_emp * n_fields:.0f} s for the map "
              f"(~{t_emp * n_fields / t_sea:.0f}x the layered map; values only, no Jacobian)")


if __name__ == "__main__":
    main()
