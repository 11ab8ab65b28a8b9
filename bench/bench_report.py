"""Benchmark of a study's report and batch (issue 48).

    python -m bench.bench_report [--repeats 3] [--variants 12]

1. **Report.** Default scenario, numba warm. Baseline: computing the report's numbers and
   building its figures once with the page's cache empty (``app.report.results.compute`` +
   ``summary`` + ``app.report.html.layout``). Measured: writing the report as *Download report*
   would with the page's cache warm (compute, the cache answering; summary; the figures; the
   HTML file). Target: ≤ 2× the baseline, and the file ≤ 5 MB. Medians of ``--repeats``.
2. **Batch.** ``--variants`` variants of the default scenario (P_h from 50 A·m in steps of 10),
   ``python -m study --vary`` in one process (``--workers 1``) and on a pool of two. Target: the
   pool ≥ 1.6× as fast, with the same numbers.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

REPORT_RATIO = 2.0
MAX_BYTES = 5_000_000
POOL_SPEEDUP = 1.6


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def bench_report(repeats):
    from app.kit.cache import SHARED
    from app.state.scenario import defaults
    from app.report import html as report, results

    values = defaults()
    results.summary(results.compute(values))  # numba warm, HoloViews and Bokeh imported
    base, write, size = [], [], 0
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "report.html"
        for _ in range(repeats):
            SHARED.clear()

            def once():
                c = results.compute(values)
                return report.layout(c, results.summary(c))

            base.append(_timed(once)[0])

            def written():  # the page's cache warm: what Download report does
                c = results.compute(values)
                report.write(path, c, results.summary(c))

            write.append(_timed(written)[0])
            size = path.stat().st_size
    b, w = statistics.median(base), statistics.median(write)
    print(f"report: numbers + figures once (cache empty) {b:.2f} s; writing the report (cache warm) "
          f"{w:.2f} s; ratio {w / b:.2f} (target ≤ {REPORT_RATIO}); file {size / 1e6:.2f} MB "
          f"(target ≤ {MAX_BYTES / 1e6:g} MB); medians of {repeats}")
    return dict(base_s=b, write_s=w, ratio=w / b, bytes=size)


def bench_batch(n):
    """The command line on ``n`` variants of P_h (every tab's numbers change with it but the
    Shape and Calibration tabs'), in a fresh process each: ``--workers 1`` and ``--workers 2``
    (both pay their imports and numba's cache loading: a pool's workers do, and so does a run)."""
    import subprocess
    import sys

    from app.state import scenario_file as sf
    from app.state.scenario import Scenario

    values = ",".join(f"{50 + 10 * i:g}" for i in range(n))
    times, numbers = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "study.yaml"
        path.write_text(sf.dumps(Scenario(), title="bench"), encoding="utf-8")
        for workers in (1, 2):
            out = Path(tmp) / f"w{workers}"
            cmd = [sys.executable, "-m", "study", str(path), "--out", str(out), "--vary",
                   f"Ph={values}", "--workers", str(workers), "--no-progress"]
            times[workers], done = _timed(lambda: subprocess.run(cmd, capture_output=True, text=True))
            if done.returncode:
                raise RuntimeError(done.stderr)
            summaries = json.loads((out / "summary.json").read_text(encoding="utf-8"))
            numbers[workers] = [json.dumps({k: s[k] for k in ("maps", "layout_design", "best_spacing",
                                                               "track")}, sort_keys=True)
                                for s in summaries]
    same = numbers[1] == numbers[2]
    print(f"batch of {n} variants (python -m study --vary Ph=…): one process {times[1]:.1f} s, "
          f"pool of 2 {times[2]:.1f} s: {times[1] / times[2]:.2f}× (target ≥ {POOL_SPEEDUP}); "
          f"same numbers: {same}")
    return dict(one_s=times[1], pool_s=times[2], speedup=times[1] / times[2], same=same)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m bench.bench_report", description=__doc__.split("\n\n")[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--variants", type=int, default=12)
    p.add_argument("--skip-batch", action="store_true")
    args = p.parse_args(argv)
    bench_report(args.repeats)
    if not args.skip_batch:
        bench_batch(args.variants)


if __name__ == "__main__":
    main()
