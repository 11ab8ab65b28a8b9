"""Benchmark of seed 003's shape pipeline (issue 27).

    python -m bench.bench_shape [--repeat 3] [--runs 100]

Targets on this 2-core machine: one seed003-fig4 pass (81 samples, 15 states; truth simulated
from the 2400-cell target with the 0.5 m baseline array, Euler along the pass, UKF and NHUKF,
the batch fit, PCA) ≤ 1 s; the batch fit of one pass ≤ 5 s (issue 37); 100 Monte-Carlo passes (stacked: one (100, 31, 15) sigma-point array per step)
≤ 30 s. Prints medians over repeats (after one warm-up run that compiles the kernels), and the
parts: the truth's simulation, and one filter over 81 steps.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from core.shape import model as md
from core.shape.experiment import Case, run_case, simulate
from core.shape.fit import fit_pass
from core.tracking import unscented as uk


def median_time(fn, repeat):
    fn()  # warm-up (compilation, caches)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m bench.bench_shape")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--runs", type=int, default=100)
    p.add_argument("--threads", type=int, default=0,
                   help="numba threads (default: numba's); 1 avoids thread start-up on the many "
                        "small kernel calls of one pass, which dominates on a loaded machine")
    a = p.parse_args(argv)
    if a.threads:
        import numba
        numba.set_num_threads(a.threads)
    case = Case("fig4")
    one = median_time(lambda: run_case(case, runs=1), a.repeat)
    mc = median_time(lambda: run_case(case, runs=a.runs), max(1, a.repeat // 2))
    sim = median_time(lambda: simulate(case), a.repeat)
    mdl = md.DipoleModel(case.track.positions)
    _, g5 = simulate(case)
    x0, P0 = md.start_state(np.zeros(3), 2400 * np.array([-3.0, 1.0, 5.0]))
    filt = median_time(lambda: uk.run_ukf(x0[None], P0, g5[None], mdl.hx, 1e-4 * np.eye(5), u=1.345),
                       a.repeat)
    res = run_case(case, runs=1, fit=False)
    starts = [np.r_[res.dipoles[f][0].ravel(), res.final[f]["moment"][0]] for f in ("ukf", "nhukf")]
    z = g5 + case.noise_g * np.random.default_rng(0).standard_normal(g5.shape)
    fit = median_time(lambda: fit_pass(z, case.track.positions, starts, case.noise_g,
                                       baseline=case.baseline), a.repeat)
    import numba
    print(f"numba threads: {numba.get_num_threads()}")
    print(f"one fig4 pass (simulate, Euler, UKF + NHUKF, batch fit, PCA): {one * 1e3:.0f} ms (target ≤ 1000 ms)")
    print(f"{a.runs} Monte-Carlo passes: {mc:.2f} s (target ≤ 30 s)")
    print(f"  parts: truth simulation {sim * 1e3:.0f} ms; one NHUKF over 81 steps {filt * 1e3:.0f} ms; "
          f"one batch fit (two starts) {fit * 1e3:.0f} ms (target ≤ 5000 ms)")
    return {"one_s": one, "mc_s": mc, "sim_s": sim, "filter_s": filt, "fit_s": fit}


if __name__ == "__main__":
    main()
