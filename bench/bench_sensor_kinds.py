"""Benchmark of issue 26 (one measurement model, magnetic kinds), same run:

- the electric 400 × 400 map (log10|det Γ|, the paper's) and CRLB map (core.crlb_maps) of this
  core against the core before the change (commit 47b19e9), each version in its own interpreter
  kept alive, the two called alternately call by call (order swapped every time), so that both
  see the same machine load; target: within 10 %. Reported: the medians, the minima (load only
  ever adds time) and the median of the paired ratios (each call against its neighbour);
- the magnetic BG CRLB map against the electric CRLB map of this core (each BG call paired with
  an electric call next to it); target: ≤ 2×.

    python -m bench.bench_sensor_kinds [--base DIR] [--n 400] [--repeat 15]

``--base`` is a checkout of the old commit (default: ``git archive 47b19e9`` into
``$TMPDIR/bench-base-47b19e9``, kept between runs so that its kernels compile once). Medians
over ``repeat`` calls after a warm-up call (compilation and caches excluded).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASE_COMMIT = "47b19e9"

WORKER = r"""
import sys, time
import core
n = int(sys.argv[1])
plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, n)
st = core.dual_station(100, 15)
mplane = core.Plane("xy", (-60, 60), (-60, 60), 15.0, n)
TASKS = {
    "map": lambda: core.evaluate_map(plane, st, velocity=(2, 2), moments=(100, 20)),
    "crlb_map": lambda: core.crlb_maps(plane, st, velocity=(2, 2), moments=(100, 20)),
    "bg_crlb_map": lambda: core.crlb_maps(mplane, [[0.0, 0.0, 0.0]], velocity=(2, 2),
                                          moments=(1e3, -2e3, 5e2), sensor="BG"),
}
print("ready", flush=True)
for line in sys.stdin:
    task = line.strip()
    t0 = time.perf_counter()
    TASKS[task]()
    print(time.perf_counter() - t0, flush=True)
"""


class Worker:
    """One interpreter of one version, kept alive: it runs a task per request and says how long
    it took (the call only; imports and compilation happen before the first timed call)."""

    def __init__(self, root, n):
        env = dict(os.environ, PYTHONPATH=str(root))
        self.proc = subprocess.Popen([sys.executable, "-c", WORKER, str(n)], cwd=root, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        if self.proc.stdout.readline().strip() != "ready":
            raise RuntimeError(f"the worker of {root} did not start")

    def time(self, task):
        self.proc.stdin.write(task + "\n")
        self.proc.stdin.flush()
        return float(self.proc.stdout.readline())

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", type=Path, default=None)
    ap.add_argument("--n", type=int, default=400)
    ap.add_argument("--repeat", type=int, default=15, help="timed calls of each task per version")
    args = ap.parse_args(argv)
    base = args.base
    if base is None:
        base = Path(tempfile.gettempdir()) / f"bench-base-{BASE_COMMIT}"
        if not (base / "core").is_dir():
            base.mkdir(parents=True, exist_ok=True)
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", BASE_COMMIT], check=True,
                                     capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
    old, new = Worker(base, args.n), Worker(ROOT, args.n)
    times = {(v, k): [] for v in ("old", "new") for k in ("map", "crlb_map")}
    times["new", "bg_crlb_map"], times["new", "crlb_map_bg"] = [], []
    try:
        for task in ("map", "crlb_map"):
            old.time(task)  # warm-up: compilation (or the cache's load) and first-touch memory
            new.time(task)
        new.time("bg_crlb_map")
        for i in range(args.repeat):  # call by call, the order swapped every time: same load
            for task in ("map", "crlb_map"):
                pair = ((old, "old"), (new, "new")) if i % 2 == 0 else ((new, "new"), (old, "old"))
                for worker, name in pair:
                    times[name, task].append(worker.time(task))
            times["new", "bg_crlb_map"].append(new.time("bg_crlb_map"))
            times["new", "crlb_map_bg"].append(new.time("crlb_map"))  # its electric neighbour
    finally:
        old.close()
        new.close()
    med = statistics.median
    print(f"{args.n} × {args.n}, {args.repeat} calls per task and version, alternated call by call "
          f"({time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores; load {os.getloadavg()[0]:.1f})")
    print("                     median before → now (ratio)     min before → now (ratio)   "
          "median of paired ratios")
    for k in ("map", "crlb_map"):
        o, w = times["old", k], times["new", k]
        paired = med(b / a for a, b in zip(o, w))
        print(f"electric {k:9s}: {1e3 * med(o):8.1f} → {1e3 * med(w):8.1f} ms ({med(w) / med(o):.3f})"
              f"   {1e3 * min(o):8.1f} → {1e3 * min(w):8.1f} ms ({min(w) / min(o):.3f})   {paired:.3f}")
    b, e = times["new", "bg_crlb_map"], times["new", "crlb_map_bg"]
    paired = med(x / y for x, y in zip(b, e))
    print(f"magnetic BG CRLB map: {1e3 * med(b):8.1f} ms = {med(b) / med(e):.2f} × the electric "
          f"CRLB map (min {min(b) / min(e):.2f}×, paired {paired:.2f}×)")


if __name__ == "__main__":
    main()
