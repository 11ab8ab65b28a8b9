"""Benchmark of issue 26 (one measurement model, magnetic kinds), same run:

- the electric 400 × 400 map (log10|det Γ|, the paper's) and CRLB map (core.crlb_maps) of this
  core against the core before the change (commit 47b19e9), each in its own interpreter,
  alternated, so that both see the same machine load; target: within 10 %;
- the magnetic BG CRLB map against the electric CRLB map of this core; target: ≤ 2×.

    python -m bench.bench_sensor_kinds [--base DIR] [--n 400] [--repeat 5] [--rounds 2]

``--base`` is a checkout of the old commit (default: ``git archive 47b19e9`` into
``$TMPDIR/bench-base-47b19e9``, kept between runs so that its kernels compile once). Medians
over ``repeat`` runs × ``rounds`` after a warm-up (compilation and caches excluded).
"""

from __future__ import annotations

import argparse
import json
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
import json, statistics, sys, time
import core
n, repeat, magnetic = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "1"
plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, n)
st = core.dual_station(100, 15)
def med(fn):
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter(); fn(); ts.append(time.perf_counter() - t0)
    return statistics.median(ts)
out = {
    "map": med(lambda: core.evaluate_map(plane, st, velocity=(2, 2), moments=(100, 20))),
    "crlb_map": med(lambda: core.crlb_maps(plane, st, velocity=(2, 2), moments=(100, 20))),
}
if magnetic:
    mplane = core.Plane("xy", (-60, 60), (-60, 60), 15.0, n)
    out["bg_crlb_map"] = med(lambda: core.crlb_maps(mplane, [[0.0, 0.0, 0.0]], velocity=(2, 2),
                                                    moments=(1e3, -2e3, 5e2), sensor="BG"))
print(json.dumps(out))
"""


def run(root, n, repeat, magnetic):
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run([sys.executable, "-c", WORKER, str(n), str(repeat), "1" if magnetic else "0"],
                         cwd=root, env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", type=Path, default=None)
    ap.add_argument("--n", type=int, default=400)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args(argv)
    base = args.base
    if base is None:
        base = Path(tempfile.gettempdir()) / f"bench-base-{BASE_COMMIT}"
        if not (base / "core").is_dir():
            base.mkdir(parents=True, exist_ok=True)
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", BASE_COMMIT], check=True,
                                     capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
    run(base, 8, 1, False)  # compile (or load) both versions' kernels outside the measurement
    run(ROOT, 8, 1, True)
    old, new = [], []
    for _ in range(args.rounds):  # alternated: both versions see the same load
        old.append(run(base, args.n, args.repeat, False))
        new.append(run(ROOT, args.n, args.repeat, True))
    med = lambda rs, k: statistics.median(r[k] for r in rs)
    print(f"{args.n} × {args.n}, medians of {args.repeat} runs × {args.rounds} rounds "
          f"({time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores)")
    for k in ("map", "crlb_map"):
        o, w = med(old, k), med(new, k)
        print(f"electric {k:9s}: before {1e3 * o:8.1f} ms, now {1e3 * w:8.1f} ms, ratio {w / o:.3f}")
    e, b = med(new, "crlb_map"), med(new, "bg_crlb_map")
    print(f"magnetic BG CRLB map: {1e3 * b:8.1f} ms = {b / e:.2f} × the electric CRLB map")


if __name__ == "__main__":
    main()
