"""A big sweep three ways on this machine: serial, the local process pool, a Dask LocalCluster.

    python -m bench.bench_sweep_dask [--repeat 3] [--nx 30] [--ny 20] [--region-n 41]

The sweep is ``mean_dopt`` (a region measure: every cell a layout criterion over
region-n² target positions) over d × z. Timed in this run, median of ``--repeat``:

- serial: :func:`core.sweep.run` with ``workers=1`` in this process (numba's default threads);
- pool: ``workers=2``, the CLI's default (spawned processes, one numba thread each; the
  pool's start-up is inside the time, as it is for every CLI run);
- LocalCluster: 2 worker processes × 1 thread, ``NUMBA_NUM_THREADS=1`` (started once, its
  start-up reported apart; the first sweep on it, which loads core and the JIT cache in the
  workers, is a warm-up and not counted).

Besides the wall time, the CPU time of one sweep summed over the processes that computed it
(this one; the pool's children, by ``getrusage``; the cluster's workers, by psutil): on a
machine shared with other jobs the wall time shows little of the parallel speed-up, the CPU
time still shows what each way costs. All three results are checked equal bit for bit. The
machine is shared: the numbers are noisy.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time

import numba
import numpy as np

from core import sweep


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(fn, repeat, cpu=time.process_time):
    """Median wall time (s), median CPU time (s) by ``cpu()`` differences, last result."""
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        c0, t0 = cpu(), time.perf_counter()
        out = fn()
        walls.append(time.perf_counter() - t0)
        cpus.append(cpu() - c0)
    return statistics.median(walls), statistics.median(cpus), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--nx", type=int, default=30, help="spacings d")
    ap.add_argument("--ny", type=int, default=20, help="depths z")
    ap.add_argument("--region-n", type=int, default=41)
    args = ap.parse_args(argv)
    import psutil
    from dask.distributed import Client, LocalCluster

    base = {k: v[0] for k, v in sweep.PARAMETERS.items()}
    settings = {"measure": "mean_dopt", "layout": "line", "stations": 2, "model": "exact",
                "steps": 3, "region": ((-300.0, 300.0), (-300.0, 300.0), args.region_n),
                "threshold": 10.0}
    x = sweep.parse_axis(f"d=2:200:{args.nx}")
    y = sweep.parse_axis(f"z=100:400:{args.ny}")
    run = lambda **kw: sweep.run(x, y, settings, base, progress=False, **kw)
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at start, "
          f"{numba.config.NUMBA_NUM_THREADS} numba threads in this process")
    print(f"sweep: mean_dopt over {args.nx} d × {args.ny} z = {args.nx * args.ny} cells, "
          f"{args.region_n}² region points each; median of {args.repeat}")
    run(workers=1)  # warm-up: JIT cache
    t_serial, c_serial, serial = timed(lambda: run(workers=1), args.repeat)
    t_pool, c_pool, pool = timed(lambda: run(workers=2), args.repeat,
                                 cpu=lambda: _children_cpu() + time.process_time())
    t0 = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0", env={"NUMBA_NUM_THREADS": "1"}) as cluster, \
            Client(cluster) as client:
        client.wait_for_workers(2)
        t_start = time.perf_counter() - t0
        run(client=client)  # warm-up: imports and JIT cache in the workers
        procs = [psutil.Process(pid) for pid in client.run(os.getpid).values()]
        workers_cpu = lambda: sum(sum(p.cpu_times()[:2]) for p in procs) + time.process_time()
        t_dask, c_dask, dask = timed(lambda: run(client=client), args.repeat, cpu=workers_cpu)
    np.testing.assert_array_equal(pool, serial)
    np.testing.assert_array_equal(dask, serial)
    print(f"{'':30} wall (s)  vs serial   CPU (s)")
    for name, wall, cpu in [("serial (workers=1)", t_serial, c_serial),
                            ("process pool (workers=2)", t_pool, c_pool),
                            ("LocalCluster (2 × 1 thread)", t_dask, c_dask)]:
        print(f"{name:30} {wall:8.2f}     {t_serial / wall:.2f}×   {cpu:7.2f}")
    print(f"(+ {t_start:.1f} s to start the LocalCluster, once)")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    print("results: all three equal bit for bit")


if __name__ == "__main__":
    main()
