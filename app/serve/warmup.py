"""Compile the numba kernels the dashboard uses, in stages, the default page's first.

On a fresh checkout (or after an edit of a kernel's source) numba compiles the kernels on first
use: a few minutes of LLVM on 2 cores. So that a newcomer is not left at a blank page,
``panel serve app`` starts this warm-up on a background thread when it loads
(``app/server_lifecycle.py``) and serves at once; until the first stage (what the default page
draws: the whole-space maps) is ready, a session gets a page that says the server is warming up
and reloads itself when the maps can be computed (:mod:`app.serve.warming`). The later stages (layered
sea, CRLB/design, tracking) go on in the background; a tab that needs one of them before it is
ready shows its busy indicator while it waits. Each stage is written to the terminal as it starts
and ends.

``python -m app.serve.warmup`` runs every stage in the foreground (the Dockerfile does, at build time).
With the on-disk cache filled it takes about a second.
"""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import core
from core import kernel_cache, pcrlb
from core.shape import Pass, Target
from core.shape.bound import shape_bound
from core.shape.experiment import Case, run_case
from core.tracking import montecarlo as core_track

from app.kit.cache import KERNEL_LOCK

_PLANE = core.Plane("xy", (-10, 10), (-10, 10), 120.0, 3)
_STATIONS = core.dual_station(100, 15)
_SEA = core.Sea(200.0, 1.0)
_MOTION = dict(velocity=(2, 2), moments=(100, 20))


def _default_maps():
    with KERNEL_LOCK:  # the default page: log10|det Γ| of the exact dipole, its veil and notes
        core.evaluate_map(_PLANE, _STATIONS, measure="log10_det", **_MOTION)
    core.gamma([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]])


def _whole_space_maps():
    for model in core.MODELS:
        for measure in core.MEASURES:
            with KERNEL_LOCK:
                core.evaluate_map(_PLANE, _STATIONS, measure=measure,
                                  sensor=core.Sensor("E", model=model), **_MOTION)


def _layered_maps():
    for measure in core.MEASURES:
        with KERNEL_LOCK:
            core.evaluate_map(_PLANE, _STATIONS, measure=measure, sensor=core.Sensor("E", sea=_SEA),
                              **_MOTION)
    core.dipole_field([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]], sea=_SEA)


def _crlb_maps():
    for sea in (None, _SEA):
        with KERNEL_LOCK:
            core.crlb_maps(_PLANE, _STATIONS, sensor=core.Sensor("E", sea=sea), **_MOTION)
    with KERNEL_LOCK:  # survey design's loss of a station (core/kernels/loss.py): every kernel
        # module compiled, so that a later start can say it loads them (core.kernel_cache.cached)
        core.station_loss(_STATIONS, core.LayoutProblem(_PLANE, velocity=(2, 2), moments=(100, 20)))


def _tracking():
    track = [[30.0 + 2 * k, 40.0, 120.0, 2.0, 0.0, 100.0, 20.0] for k in range(3)]
    with KERNEL_LOCK:
        pcrlb(track, core.SensorModel(_STATIONS))
    case = core_track.TrackCase(name="warm-up", stations=tuple(map(tuple, _STATIONS)), axes=3,
                                start=(30.0, 40.0, 120.0), heading=0.0, steps=12)
    for name in core_track.FILTERS:
        with KERNEL_LOCK:
            core_track.monte_carlo(case, filter=name, runs=1, seed=0, workers=1)


def _magnetic_maps():
    """The magnetic kinds (issue 26): the maps of the Maps tab and the CRLB maps of the design
    tab, for each kind the sidebar offers."""
    magnetic = dict(velocity=(2, 2), moments=(-3000.0, 1000.0, 5000.0))
    for kind in ("B", "G", "BG"):
        for measure in ("d_optimal", "crlb_position"):
            with KERNEL_LOCK:
                core.evaluate_map(_PLANE, _STATIONS, measure=measure, sensor=kind, **magnetic)
    with KERNEL_LOCK:
        core.crlb_maps(_PLANE, _STATIONS, sensor="BG", **magnetic)
        # a few points: the kernels' serial twins (core.kernels.magnetic.BLOCK)
        core.gamma([30, 40, 120, 2, 2, -3000.0, 1000.0, 5000.0], _STATIONS, sensor="BG", steps=3)
        core.gradient_tensor([30, 40, 120, 2, 2, -3000.0, 1000.0, 5000.0], _STATIONS)


def _shape():
    target = Target(height=0.3, radius=0.1)  # a few cells, a short pass: the kernels, not the work
    track = Pass(start=(-2.0, 2.0, -2.0), velocity=(1.0, 0.0, 0.0), rate=1.0, samples=12)
    with KERNEL_LOCK:
        run_case(Case(name="warm-up", target=target, track=track), runs=1)
        shape_bound(target, track)


#: (what the stage compiles, the function that compiles it), in the order they run: what the
#: default page draws first.
STAGES = (
    ("the default page's maps (log10|det Γ|, whole space)", _default_maps),
    ("the other measures and the paper's formulas", _whole_space_maps),
    ("layered-sea maps", _layered_maps),
    ("CRLB maps (Layout design tab)", _crlb_maps),
    ("tracking filters and bound (Track tab)", _tracking),
    ("magnetic sensor maps (magnetometer, gradiometer, both)", _magnetic_maps),
    ("gradiometer filters and shape bound (Shape tab)", _shape),
)


def cache_present():
    """Whether numba's cache in use (NUMBA_CACHE_DIR, else core's ``__pycache__``) holds compiled
    kernels of every kernel module (otherwise this start compiles: it says so)."""
    return kernel_cache.cached()


class Warmup:
    """The stages' progress; one per process (:data:`WARMUP`). Thread-safe to read."""

    def __init__(self, stages=STAGES, out=None, child=False):
        self.stages = stages
        self.out = out
        self.child = child
        self.done = [threading.Event() for _ in stages]
        self.current = None  # index of the stage compiling now
        self.started = None  # time.monotonic() when the warm-up began
        self.error = None
        self._lock = threading.Lock()
        self._thread = None

    def _say(self, text):
        print(f"[warm-up] {text}", file=self.out or sys.stderr, flush=True)

    def _header(self):
        self._say("compiling the numba kernels: first start after install or an edit, a few "
                  "minutes on 2 cores; the page says so meanwhile" if not cache_present() else
                  "loading the compiled numba kernels from numba's cache")

    def run(self, header=True):
        """Run every stage in turn, in this thread; returns the seconds taken. ``header=False``:
        the caller (a parent process) has said already what the warm-up does."""
        self.started = time.monotonic()
        if header:
            self._header()
        try:
            for i, (what, compile_stage) in enumerate(self.stages):
                self.current = i
                t0 = time.monotonic()
                self._say(f"{i + 1}/{len(self.stages)}: {what} ...")
                compile_stage()
                self.done[i].set()
                self._say(f"{i + 1}/{len(self.stages)}: {what} ready in "
                          f"{time.monotonic() - t0:.1f} s")
        except Exception as exc:  # said on the terminal and on the page, never swallowed
            self.error = f"{type(exc).__name__}: {exc}"
            self._say(f"FAILED: {self.error}")
            raise
        finally:
            self.current = None
        elapsed = time.monotonic() - self.started
        self._say(f"all kernels ready in {elapsed:.1f} s")
        return elapsed

    def start(self):
        """Run the stages on a background thread, once per process. Returns True when this call
        started it, False when it was running or done already."""
        with self._lock:
            if self._thread is not None:
                return False
            self._thread = threading.Thread(target=self._background, name="warm-up", daemon=True)
            self._thread.start()
            return True

    def _background(self):
        try:
            self.run_in_child() if self.child else self.run()
        except Exception:  # noqa: BLE001 (already said; the thread just ends)
            pass

    def run_in_child(self):
        """Run ``python -m app.serve.warmup`` (the same stages) in a child process, relaying its lines
        and marking each stage done as the child reports it. Numba writes what the child
        compiles to its on-disk cache, from which this process loads a kernel in a fraction of a
        second on first use. So the server process keeps its GIL and its kernel lock for the
        sessions while LLVM works (in-process, a session's first maps waited ~40 s behind the
        later stages' compiles), and only one of the two cores goes to compiling."""
        self.started = time.monotonic()
        self._header()  # at once: the child's first line comes after its imports, seconds later
        cmd = [sys.executable, "-m", "app.serve.warmup", "--no-header"]
        proc = subprocess.Popen(cmd, cwd=Path(__file__).resolve().parents[1], text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, bufsize=1)
        tail = []
        for line in proc.stdout:
            line = line.rstrip("\n")
            tail = (tail + [line])[-20:]
            print(line, file=self.out or sys.stderr, flush=True)
            m = _STAGE_LINE.match(line)
            if m:
                i = int(m["i"]) - 1
                if m["ready"]:
                    self.done[i].set()
                    self.current = None
                else:
                    self.current = i
        if proc.wait() != 0 or not self.ready(len(self.stages) - 1):
            self.error = f"python -m app.serve.warmup exited with {proc.returncode}: " + \
                (tail[-1] if tail else "no output")
            self._say(f"FAILED: {self.error}")
            raise RuntimeError(self.error)

    def ready(self, stage=0):
        """Whether stage ``stage`` (0: the default page's maps) and all before it are compiled."""
        return all(e.is_set() for e in self.done[: stage + 1])

    def status(self):
        """One line for the page: which stage compiles now and for how long."""
        if self.error:
            return f"The warm-up failed: {self.error}. See the server's terminal."
        if self.started is None:
            return "Starting the warm-up…"
        elapsed = time.monotonic() - self.started
        i = self.current
        stage = "" if i is None else f" — stage {i + 1} of {len(self.stages)}: {self.stages[i][0]}"
        return f"Compiling the numba kernels ({elapsed:.0f} s so far){stage}."


#: The title of the warming-up page (app/serve/warming.py), in the HTML that ``/app`` returns (the page's
#: content comes later, over the websocket): a client that fetches ``/app`` and finds it knows the
#: dashboard is not served yet (app.serve.cluster and the tests wait for its absence).
WARMING_MARK = "Dipole observability explorer: warming up"

#: A stage's lines as :meth:`Warmup.run` writes them: "i/N: what ..." and "i/N: what ready in".
_STAGE_LINE = re.compile(r"^\[warm-up\] (?P<i>\d+)/\d+: .*?(?P<ready> ready in [\d.]+ s)?$")

#: The server process's warm-up (in a child process), started by ``app/server_lifecycle.py``.
WARMUP = Warmup(child=True)


def compile_kernels(out=None, header=True):
    """Run every stage now, in this process; returns the seconds taken."""
    return Warmup(out=out).run(header=header)


if __name__ == "__main__":
    compile_kernels(out=sys.stdout, header="--no-header" not in sys.argv[1:])
