"""Where independent evaluations run: here, in local worker processes, or on a
``dask.distributed`` cluster.

The sweep (:func:`core.sweep.run`), the Monte-Carlo tracking (:func:`core.tracking.montecarlo.monte_carlo`)
and the layout search (:func:`core.spacing_curve`, :func:`core.best_spacing`,
:func:`core.optimise_layout`) evaluate many independent cells, chunks or candidates through
:func:`run_calls` (or :func:`map_ordered`). Given a ``client`` they go to the cluster; without
one they run here or in spawned processes with one numba thread each.

``dask`` and ``distributed`` are an optional dependency (``pip install '.[dask]'``), imported
only inside these functions, so ``import core`` never loads them.

In each worker process the evaluations run one at a time (a process-wide lock: numba's
``workqueue`` layer aborts when ``parallel=True`` kernels are launched from several threads);
worker set-up, failures and why the results equal the serial ones bit for bit: docs/dask.md.
"""

from __future__ import annotations

import multiprocessing
import threading
from concurrent.futures import ProcessPoolExecutor, as_completed

__all__ = ["DEFAULT_TIMEOUT", "check_client", "connect", "map_ordered", "map_unordered", "run_calls"]

#: Seconds to wait for a scheduler (and for its first worker) before giving up.
DEFAULT_TIMEOUT = 10.0

#: One evaluation at a time per worker process (see the module notes).
_EVALUATION_LOCK = threading.Lock()


def _import_distributed():
    try:
        import distributed
    except ImportError:
        raise ImportError("a Dask scheduler or client needs the optional dependency "
                          "dask.distributed: pip install 'dipole-observability[dask]'") from None
    return distributed


def connect(address, *, timeout=DEFAULT_TIMEOUT):
    """Client of the ``dask.distributed`` scheduler at ``address``, with at least one worker.

    Parameters
    ----------
    address : str
        Scheduler address, e.g. ``"tcp://10.0.0.5:8786"`` (what ``dask scheduler`` prints).
    timeout : float
        Seconds (> 0) to wait for the scheduler to answer, and again for a first worker.

    Returns
    -------
    distributed.Client
        Not set as the default client. Close it (``client.close()``) when done.

    Raises
    ------
    ValueError
        ``address`` is not a string, or malformed (no port, unknown scheme), or bad timeout.
    ConnectionError
        Nothing answers at ``address`` within ``timeout`` (or not a Dask scheduler), or the
        scheduler has no worker within ``timeout``.
    ImportError
        dask.distributed is not installed.
    """
    if not isinstance(address, str) or not address.strip():
        raise ValueError(f"scheduler address must be a string like 'tcp://HOST:8786'; got {address!r}")
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise ValueError(f"timeout must be a number of seconds > 0; got {timeout!r}")
    distributed = _import_distributed()
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect as comm_connect
    from distributed.security import Security

    security = Security()  # from Dask's configuration, as a Client's: tls:// works the same way

    async def probe():  # a Client that fails to connect leaves a noisy __del__ behind: probe first
        comm = await comm_connect(address, timeout=timeout,
                                  **security.get_connection_args("client"))
        await comm.close()

    try:  # in a thread of its own: the caller may be running an event loop (Jupyter)
        with ThreadPoolExecutor(1) as pool:
            pool.submit(asyncio.run, probe()).result()
    except ValueError as exc:
        raise ValueError(f"bad scheduler address {address!r}: {exc}") from None
    except (OSError, asyncio.TimeoutError) as exc:
        raise ConnectionError(f"cannot reach a Dask scheduler at {address!r} within "
                              f"{timeout:g} s: {exc}") from None
    except Exception as exc:  # something answered, but not with Dask's protocol
        raise ConnectionError(f"{address!r} answered, but not as a Dask scheduler "
                              f"({type(exc).__name__}: {exc})") from None
    try:
        client = distributed.Client(address, timeout=timeout, set_as_default=False,
                                    security=security)
    except (OSError, asyncio.TimeoutError) as exc:  # answered the probe, then too slow
        raise ConnectionError(f"the Dask scheduler at {address!r} did not complete the "
                              f"handshake within {timeout:g} s: {exc!r}") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, asyncio.TimeoutError):
        client.close()
        raise ConnectionError(f"the Dask scheduler at {address!r} has no worker after "
                              f"{timeout:g} s; start one with: dask worker {address}") from None
    return client


def check_client(client):
    """``client`` if it is a ``distributed.Client``; ValueError otherwise."""
    distributed = _import_distributed()
    if not isinstance(client, distributed.Client):
        raise ValueError(f"client must be a dask.distributed.Client (or None); "
                         f"got {type(client).__name__}")
    return client


def _evaluate(fn, args):
    """Run on a worker: ``fn(*args)``, one at a time per process."""
    with _EVALUATION_LOCK:
        return fn(*args)


def map_unordered(client, fn, calls):
    """Yield ``(i, fn(*calls[i]))`` as the cluster finishes them (completion order).

    Parameters
    ----------
    client : distributed.Client
    fn : callable
        Importable on the workers (module function, or a closure over picklable values).
    calls : sequence of tuple
        Positional arguments of each call.

    Raises
    ------
    Exception
        The first exception a call raised on a worker, re-raised here.
    """
    distributed = _import_distributed()
    calls = list(calls)
    futures = client.map(_evaluate, [fn] * len(calls), calls, pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    try:
        for fut in distributed.as_completed(futures, loop=client.loop):  # not the default client
            yield index[fut.key], fut.result()
    finally:
        client.cancel(futures)  # no-op for finished ones; stops the rest after an error


def map_ordered(client, fn, values):
    """``[fn(v) for v in values]`` on the cluster, in order (see :func:`map_unordered`)."""
    values = list(values)
    out = [None] * len(values)
    for i, result in map_unordered(client, fn, [(v,) for v in values]):
        out[i] = result
    return out


def _one_numba_thread():
    """A local worker process's initializer: the pool supplies the parallelism."""
    import numba

    numba.set_num_threads(1)


def run_calls(fn, calls, *, workers=1, client=None):
    """Yield ``(i, fn(*calls[i]))`` in completion order: on the cluster of ``client``
    (:func:`map_unordered`), else here (``workers`` 1) or in ``workers`` spawned processes, each
    with one numba thread so that the two levels of parallelism do not oversubscribe the cores
    (spawn, not fork: forking a process whose numba thread pool runs is unsafe)."""
    calls = list(calls)
    if client is not None:
        yield from map_unordered(check_client(client), fn, calls)
    elif workers == 1:
        for i, args in enumerate(calls):
            yield i, fn(*args)
    else:
        with ProcessPoolExecutor(max_workers=workers, initializer=_one_numba_thread,
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(fn, *args): i for i, args in enumerate(calls)}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
