"""Benchmark of the magnetometer calibration at real log lengths (issue 28).

    python -m bench.bench_calibration [--sizes 5000,50000,1000000] [--keep DIR]

Targets: a 50 000-reading log solved by the CLI in ≤ 5 s and 1 000 000 readings in ≤ 60 s,
process start included, with memory linear in N. For each N it writes a simulated log (seed
004's simulation: K, Bp, Be, attitude ranges, uniform errors ±100 nT and ±0.05°) to a
temporary CSV (not committed: 62 MB at 1e6), then

- runs ``python -m core.calibration LOG --be … --json`` in a fresh process: wall time, and
  peak resident memory of the child (``resource.getrusage(RUSAGE_CHILDREN)``; the children run
  one after another, smallest first, so the maximum so far is this run's);
- times each step in this process (parse, least squares, observability, CRLB with angle
  errors, Kalman filter (the CLI's default iterations), geomagnetic solution, misfit check) and
  its peak traced numpy memory (tracemalloc, a separate run so that tracing does not slow the
  timed one).

Prints a table; the machine may be shared, so compare sizes within one run.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

import core
from core import calibration as cal

ROOT = Path(__file__).resolve().parents[1]
SIM = core.SEED004_SIMULATION
K, BP, BE = np.array(SIM["K"]), np.array(SIM["Bp"]), np.array(SIM["be"])
SIGMA, ANGLE_SIGMA_DEG = 100 / np.sqrt(3), 0.05 / np.sqrt(3)


def write_log(n, path, seed=0):
    """A simulated log of n readings as the CLI reads it (B to 1 pT, angles to 0.1 µrad)."""
    rng = np.random.default_rng(seed)
    B, att = core.simulate_ship_data(K, BP, core.random_attitudes(n, rng), BE, rng, noise_nt=100,
                                     angle_noise_deg=0.05)
    with open(path, "w") as f:
        f.write(",".join(cal.CSV_COLUMNS) + "\n")
        np.savetxt(f, np.c_[B, att], delimiter=",", fmt=["%.3f"] * 3 + ["%.7f"] * 3)


def steps(path):
    """The CLI's steps, in order, as (name, function of the previous results)."""
    sa = np.deg2rad(ANGLE_SIGMA_DEG)
    state = {}

    def parse():
        state["B"], state["att"] = core.read_attitude_csv(path)

    def lsq():
        state["lsq"] = core.lsq_calibrate(state["B"], state["att"], BE)

    def kalman():
        it = cal.default_iterations(state["att"].shape[0])
        state["kal"] = core.kalman_calibrate(state["B"], state["att"], BE, sigma_nt=SIGMA,
                                             iterations=it)

    return state, [
        ("parse", parse),
        ("least squares", lsq),
        ("observability", lambda: core.calibration_observability(state["att"], BE)),
        ("CRLB", lambda: core.calibration_crlb(state["att"], BE, noise_nt=SIGMA, angle_noise_rad=sa,
                                               K=state["lsq"].K)),
        ("Kalman", kalman),
        ("geomagnetic", lambda: core.geomagnetic_error(
            core.geomagnetic_solution(state["B"], state["att"], state["kal"].K, state["kal"].Bp), BE)),
        ("misfit check", lambda: core.fit_diagnosis(state["B"], state["att"], BE, noise_nt=SIGMA,
                                                    angle_noise_rad=sa)),
    ]


def measure_steps(path):
    _, timed = steps(path)
    times = {}
    for name, fn in timed:
        t0 = time.perf_counter()
        fn()
        times[name] = time.perf_counter() - t0
    _, traced = steps(path)
    peaks = {}
    for name, fn in traced:
        tracemalloc.start()
        fn()
        peaks[name] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return times, peaks


def measure_cli(path):
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "core.calibration", str(path),
                        "--be", ",".join(f"{v:g}" for v in BE), "--sigma-nt", f"{SIGMA:.6g}",
                        "--angle-sigma-deg", f"{ANGLE_SIGMA_DEG:.6g}", "--json"],
                       cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(p.stderr)
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024  # bytes (Linux: kB)
    return wall, rss, json.loads(p.stdout)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench.bench_calibration")
    ap.add_argument("--sizes", default="5000,50000,1000000", help="comma-separated N")
    ap.add_argument("--keep", default=None, help="write the logs here instead of a temporary dir")
    a = ap.parse_args(argv)
    sizes = sorted(int(s) for s in a.sizes.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(a.keep or tmp)
        rows = []
        for n in sizes:
            path = d / f"log_{n}.csv"
            write_log(n, path)
            wall, rss, r = measure_cli(path)
            times, peaks = measure_steps(path)
            rows.append((n, path.stat().st_size, wall, rss, times, peaks, r))
    print(f"{'N':>9} {'CSV MB':>7} {'CLI s':>7} {'CLI RSS MB':>10} {'RSS/N B':>8}   "
          "in-process step s (peak traced MB)")
    for n, size, wall, rss, times, peaks, r in rows:
        st = ", ".join(f"{k} {times[k]:.2f} ({peaks[k] / 2 ** 20:.0f})" for k in times)
        print(f"{n:>9} {size / 2 ** 20:7.1f} {wall:7.2f} {rss / 2 ** 20:10.0f} {rss / n:8.0f}   {st}")
        print(f"{'':>9} Kalman iterations {r['kalman']['iterations']}, rank {r['rank']}, "
              f"diagnosis {r['diagnosis']['level']}, Be RMS error {r['be_rms_nT']:.1f} nT")
    print("targets: N = 50 000 CLI ≤ 5 s; N = 1 000 000 CLI ≤ 60 s; memory linear in N")


if __name__ == "__main__":
    main()
