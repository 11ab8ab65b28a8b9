"""Benchmark of survey design (issue 49).

    python -m bench.bench_design [--repeat 5] [--n 200] [--region 31]

In the same run, interleaved:

1. The N−1 loss map (:func:`core.station_loss`: the CRLB with each of 4 stations lost, the worst
   single loss and the coverage left) at n × n against one CRLB map at n × n, both the design
   tab's :func:`core.crlb_maps` and the fused-kernel ``evaluate_map(measure="crlb_position")``.
   Target: loss ≤ 1.5 × one CRLB map (:func:`core.crlb_maps`).
2. A constrained free optimisation: 4 new stations beside 2 fixed ones, 3 forbidden polygons,
   a 40 m minimum spacing, the coverage criterion (T = 10 m) over a ``--region``² x–y region.
   Target: ≤ 15 s.

Geometry: targets at depth 120 m over x, y ∈ [−300, 300] m, v = (2, 2) m/s,
(Ph, Pv) = (100, 20) A·m; stations at 100 m.
"""

from __future__ import annotations

import argparse
import os

import numba
import numpy as np

import core
from bench.bench_sea import interleaved_medians  # one timing loop for the benchmarks that compare in one run

VELOCITY, MOMENTS = (2.0, 2.0), (100.0, 20.0)
FOUR = np.array([[-100.0, -100.0, 100.0], [100.0, 100.0, 100.0], [50.0, -80.0, 100.0],
                 [-60.0, 90.0, 100.0]])
ZONES = ([(-250, -250), (-150, -250), (-150, -100), (-250, -100)],  # a mooring-free box
         [(50, 50), (200, 60), (120, 200)],  # a wreck
         [(-100, 150), (0, 150), (0, 250), (-100, 250)])  # a cable landing
FIXED = [[-200.0, 0.0, 100.0], [200.0, -200.0, 100.0]]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--region", type=int, default=31)
    args = ap.parse_args(argv)
    print(f"machine: {os.cpu_count()} CPUs, {numba.config.NUMBA_NUM_THREADS} numba threads, "
          f"numba {numba.__version__}; load {os.getloadavg()[0]:.1f}; median of {args.repeat}")

    plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, args.n)
    problem = core.LayoutProblem(plane, threshold=10.0)
    loss, crlb, fused = interleaved_medians([
        lambda: core.station_loss(FOUR, problem),
        lambda: core.crlb_maps(plane, FOUR, velocity=VELOCITY, moments=MOMENTS),
        lambda: core.evaluate_map(plane, FOUR, velocity=VELOCITY, moments=MOMENTS,
                                  measure="crlb_position"),
    ], args.repeat)
    print(f"1. N-1 loss map {args.n}^2, 4 stations: {loss:.3f} s; one crlb_maps {crlb:.3f} s "
          f"({loss / crlb:.2f}x, target <= 1.5x); one evaluate_map crlb_position {fused:.3f} s "
          f"({loss / fused:.2f}x)")

    region = core.Plane("xy", (-300, 300), (-300, 300), 120.0, args.region)
    constrained = core.LayoutProblem(region, criterion="area_crlb", threshold=10.0,
                                     constraints=core.LayoutConstraints(
                                         fixed=FIXED, zones=ZONES, min_spacing=40.0))
    result = []
    (opt,) = interleaved_medians([lambda: result.append(
        core.optimise_layout("free", 4, constrained))], max(1, args.repeat // 2))
    r = result[-1]
    print(f"2. constrained free optimisation, 4 new + 2 fixed, 3 zones, coverage, region "
          f"{args.region}^2: {opt:.2f} s (target <= 15 s); coverage {r.value:.3f}, "
          f"{r.nfev} evaluations, constraints broken: {constrained.constraints.violations(r.stations)}")


if __name__ == "__main__":
    main()
