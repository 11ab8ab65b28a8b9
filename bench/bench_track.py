"""Benchmark of tracking (issue 18): the 12-filter bank over 100 Monte-Carlo runs, the PCRLB,
and the same EKF in Stone Soup.

    python -m bench.bench_track [--repeat 3] [--runs 100]

Targets: 100 runs × 12 filters × 300 steps × 2 stations (360 000 filter updates) ≤ 10 s on a
2-core machine; the PCRLB of a 300-step track ≤ 50 ms. Prints medians over repeats, measured in
this run:

- the bank alone on pre-simulated measurements, in this process (one (1200, 7) stack per step);
- the whole Monte-Carlo (simulate, filter, PCRLB) in this process and in 2 spawned processes
  (process start-up included: that is what a user waits for);
- the PCRLB of one 300-step track;
- one EKF over 300 steps, ours (one filter, not stacked) and Stone Soup's
  ExtendedKalmanPredictor / ExtendedKalmanUpdater on the same model (our measurement function and
  exact Jacobian behind Stone Soup's public measurement-model API), and the per-update ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from datetime import datetime, timedelta

import numba
import numpy as np

import core
from core.tracking import montecarlo as tr


def median_time(fn, repeat, warm=True):
    if warm:
        fn()  # warm-up (compilation, caches)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _stonesoup_ekf(sensors, F, Q, x0, P0, ys):
    from stonesoup.base import Property
    from stonesoup.models.measurement.nonlinear import NonLinearGaussianMeasurement
    from stonesoup.models.transition.linear import LinearGaussianTimeInvariantTransitionModel
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.types.array import StateVector
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater

    class DipoleFieldMeasurement(NonLinearGaussianMeasurement):
        model: object = Property(doc="core.SensorModel")

        @property
        def ndim_meas(self):
            return self.model.n_meas

        def function(self, state, noise=False, **kwargs):
            return StateVector(self.model.h(np.asarray(state.state_vector, float)[:, 0]))

        def jacobian(self, state, **kwargs):
            return self.model.jacobian(np.asarray(state.state_vector, float)[:, 0])

    mm = DipoleFieldMeasurement(model=sensors, ndim_state=7, mapping=tuple(range(7)),
                                noise_covar=sensors.R)
    predictor = ExtendedKalmanPredictor(
        LinearGaussianTimeInvariantTransitionModel(transition_matrix=F, covariance_matrix=Q))
    updater = ExtendedKalmanUpdater(mm, use_joseph_cov=True)
    t0 = datetime(2026, 1, 1)
    state = GaussianState(x0[:, None], P0, timestamp=t0)
    out = []
    for k, y in enumerate(ys):
        t = t0 + timedelta(seconds=k)
        pred = state if k == 0 else predictor.predict(state, timestamp=t)
        state = updater.update(SingleHypothesis(pred, Detection(y[:, None], timestamp=t,
                                                                measurement_model=mm)))
        out.append(np.asarray(state.state_vector)[:, 0])
    return np.array(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--runs", type=int, default=100)
    args = ap.parse_args(argv)
    case = tr.CASES["seed001-sim"]
    sensors = case.sensors()
    F, Q = core.dwna_model(case.T, case.sigma_a, case.alpha)
    ids = list(range(args.runs))
    truths, _ = tr._truths_and_x0(case, "bank", ids, 0, False)
    ys = tr._measurements(case, sensors, truths, ids, 0)
    n_h = len(core.BANK_STRENGTHS) * len(core.BANK_BEARINGS)
    updates = args.runs * n_h * case.steps
    load = os.getloadavg()
    print(f"machine: {os.cpu_count()} CPUs, {numba.config.NUMBA_NUM_THREADS} numba threads, load "
          f"average {load[0]:.1f} / {load[1]:.1f} (1 / 5 min; other work shares these cores)")
    print(f"case seed001-sim: {args.runs} runs x {n_h} filters x {case.steps} steps x "
          f"{sensors.stations.shape[0]} stations = {updates} filter updates; median of {args.repeat}")

    t_bank = median_time(lambda: core.run_bank(ys, sensors, F, Q, depth=case.bank_depth, n_pu=1),
                         args.repeat)
    print(f"bank (EKF units), filters only, 1 process:      {t_bank:7.2f} s   "
          f"({1e6 * t_bank / updates:.1f} µs per filter update)")
    t_bank3 = median_time(lambda: core.run_bank(ys, sensors, F, Q, depth=case.bank_depth, n_pu=3),
                          1, warm=False)
    print(f"bank (PUEKF N_pu = 3), filters only, 1 process: {t_bank3:7.2f} s   (1 run)")
    t_mc1 = median_time(lambda: tr.monte_carlo(case, filter="bank", runs=args.runs, workers=1),
                        args.repeat, warm=False)
    print(f"Monte-Carlo (simulate + bank + PCRLB), 1 process:   {t_mc1:7.2f} s")
    t_mc2 = median_time(lambda: tr.monte_carlo(case, filter="bank", runs=args.runs, workers=2),
                        args.repeat, warm=False)
    print(f"Monte-Carlo, 2 spawned processes (start-up incl.):  {t_mc2:7.2f} s")

    track = case.nominal_track()
    t_pcrlb = median_time(lambda: core.pcrlb(track, sensors, T=case.T, sigma_a=case.sigma_a,
                                             alpha=case.alpha), 20)
    print(f"PCRLB, one 300-step track:                          {1e3 * t_pcrlb:7.2f} ms")

    x0 = track[0] + np.array([10.0, -10.0, 0.2, 0.2, -0.2, 10.0, 2.0])
    P0 = case.prior_cov()
    y1 = ys[0]

    def ours_one():
        return core.run_filters(x0[None], P0, y1[None], sensors, F, Q).x[0]

    t_ours = median_time(ours_one, args.repeat)
    try:
        ref = _stonesoup_ekf(sensors, F, Q, x0, P0, y1)
    except ImportError:
        print("Stone Soup not installed (pip install stonesoup): comparison skipped")
        return
    t_ss = median_time(lambda: _stonesoup_ekf(sensors, F, Q, x0, P0, y1), args.repeat, warm=False)
    diff = np.max(np.abs(ours_one() - ref) / (np.abs(ref) + 1.0))
    print(f"one EKF x 300 steps, ours (unstacked):              {1e3 * t_ours:7.1f} ms")
    print(f"one EKF x 300 steps, Stone Soup:                    {1e3 * t_ss:7.1f} ms   "
          f"(x{t_ss / t_ours:.0f} ours; largest relative difference {diff:.1e})")
    print(f"Stone Soup for the {updates} updates, extrapolated:  {t_ss / case.steps * updates:7.0f} s   "
          f"(x{t_ss / case.steps * updates / t_bank:.0f} the stacked bank)")


if __name__ == "__main__":
    main()
