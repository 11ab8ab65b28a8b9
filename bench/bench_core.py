"""Benchmark of the core maps (issue: ≤ 25 ms for a 400 × 400 dual log10|det Γ| map,
≥ 20× faster than the straightforward way, equal to it to 1e-8).

    python -m bench.bench_core [--repeat 15] [--n 400]

Prints medians over repeated runs, measured in this run: core's compiled map, the
straightforward way (sympy Jacobian lambdified to numpy, Γ assembled with numpy, slogdet), the
ratio, the largest difference between them, the CRLB map, and the peak memory of a
1000 × 1000 map.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import tracemalloc

import numba
import numpy as np

import core
from support import symbolic

STATIONS = core.dual_station(100, 15)
VELOCITY, MOMENTS = (2.0, 2.0), (100.0, 20.0)


def median_time(fn, repeat):
    fn()  # warm-up (compilation, caches)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--n", type=int, default=400)
    args = ap.parse_args(argv)
    plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, args.n)
    states = plane.states(VELOCITY, MOMENTS)

    def ours(measure="log10_det"):
        return core.evaluate_map(plane, STATIONS, velocity=VELOCITY, moments=MOMENTS, measure=measure)

    def straightforward():
        return symbolic.log10_abs_det_gamma(states, STATIONS)

    print(f"machine: {os.cpu_count()} CPUs, {numba.config.NUMBA_NUM_THREADS} numba threads, numba {numba.__version__}, "
          f"numpy {np.__version__}")
    print(f"grid {args.n} x {args.n}, dual stations d = 15 m, exact model, paper rule; median of {args.repeat}")
    t_ours, t_ours_min = median_time(ours, args.repeat)
    numba.set_num_threads(1)
    t_one, _ = median_time(ours, args.repeat)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    t_ref, _ = median_time(straightforward, max(3, args.repeat // 5))
    diff = np.nanmax(np.abs(ours().value - straightforward()))
    print(f"log10|det Γ| map, core (all threads) : {t_ours * 1e3:8.1f} ms  (min {t_ours_min * 1e3:.1f})")
    print(f"log10|det Γ| map, core (1 thread)    : {t_one * 1e3:8.1f} ms")
    print(f"log10|det Γ| map, sympy + slogdet     : {t_ref * 1e3:8.1f} ms")
    print(f"speed-up vs straightforward           : {t_ref / t_ours:8.1f} x")
    print(f"max |difference| in log10|det Γ|      : {diff:.2e}  (bar: 1e-8)")
    t_crlb, _ = median_time(lambda: ours("crlb_position"), args.repeat)
    print(f"CRLB position map (N = {core.DEFAULT_STEPS} instants)  : {t_crlb * 1e3:8.1f} ms")
    big = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 1000)
    tracemalloc.start()
    t0 = time.perf_counter()
    core.evaluate_map(big, STATIONS, velocity=VELOCITY, moments=MOMENTS)
    elapsed = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(f"1000 x 1000 map: {elapsed * 1e3:.0f} ms, peak Python-side allocation {peak / 2**20:.1f} MiB "
          f"(outputs alone: {2 * 1000 * 1000 * 8 / 2**20 + 1e6 / 2**20:.1f} MiB)")


if __name__ == "__main__":
    main()
