"""One session's calibration of a real-length log does not hold up another session (issue 28).

The real served app (``panel serve app`` as the README serves it, support.server) and two websocket
sessions (bench.load_test's ``Client``, as tests/test_server_concurrency.py): session A opens the
Calibration tab and uploads a 50,000-reading log (an 83-minute log at 10 Hz, ~3.4 MB of CSV,
simulated with core.calibration as seed 004's ship; its computation takes ~3 s in-process, longer
in the server); once the server has started it (A's page shows its busy indicator over the
results), session B releases a slider. B's new maps must arrive within 1 s, before A's result,
and be right: their images are compared with core.evaluate_map's values for B's scenario. Were
the calibration computed on the server's event loop, B's event would wait for all of it.
"""

import html
import io
import os
import re
import threading
import time

import numpy as np
import pytest
from bokeh.document.events import MessageSentEvent, ModelChangedEvent
from bokeh.models import ColumnDataSource
from panel.models.file_dropper import UploadEvent

import core
from app.state.scenario import Scenario
from app.tabs.calibration.calibration import UPLOAD_CHUNK_BYTES
from app.tabs.maps.compute import colour_range
from bench.load_test import Client
from core import calibration as cal
from support.server import close_client, on_thread, served_app

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it measures how long a session waits behind another's upload"

#: Readings in the uploaded log (issue 28's size).
READINGS = 50_000
#: B's slider change must be answered (its three maps received) within this (s), as the issue says.
ANSWER_WITHIN = 1.0
#: B's scenario: two observable dual layouts (Fig. 6's comparison, d = 10 m against 15 m), so
#: every value of both maps is a well-conditioned number (a single station's map is round-off).
B_ARGS = {"comparison": "Spacing d − reference d (Fig. 6)"}
#: The css class of Panel's busy indicator (a component's ``loading``).
LOADING = "pn-loading"
#: The Calibration tab's index among the tabs (app.page).
CALIBRATION_TAB = 3


@pytest.fixture(scope="module")
def server():
    os.environ.setdefault("QUIET_SERVER", "1")
    with served_app() as (url, _):
        yield url


class SentUpload(UploadEvent):
    """Panel's upload event as the browser's FileDropper sends it. Bokeh serialises a model event's
    ``event_values()``, which for Panel's class carry only the model (the browser's BokehJS event
    carries the piece): the piece is added here, as the browser sends it."""

    def event_values(self):
        return dict(super().event_values(), data=self.data)


def log_csv(seed):
    """A READINGS-row CSV as the tab accepts it (B1, B2, B3 in nT; psi, theta, phi in rad):
    seed 004's simulated ship on random attitudes, 100 nT and 0.05° errors."""
    rng = np.random.default_rng(seed)
    sim = cal.SEED004_SIMULATION
    att = cal.random_attitudes(READINGS, rng)
    B, rec = cal.simulate_ship_data(np.array(sim["K"]), np.array(sim["Bp"]), att, np.array(sim["be"]),
                                    rng, noise_nt=100.0, angle_noise_deg=0.05)
    out = io.StringIO()
    np.savetxt(out, np.hstack([B, rec]), delimiter=",", fmt=["%.3f"] * 3 + ["%.7f"] * 3,
               header="B1,B2,B3,psi,theta,phi", comments="")
    return out.getvalue().encode()


def expected_images(ph):
    """The normalised images of B's maps A and B at P_h = ``ph`` from core.evaluate_map: values
    (v − low) / (high − low) with the colour range the page gives A and B together
    (app.tabs.maps.compute.colour_range: 0.5–99.5 % of their finite values)."""
    s = Scenario(**B_ARGS, Ph=ph)
    opts = s.snapshot().core_options()
    measure = opts.pop("measure")
    values = [core.evaluate_map(s.snapshot().core_plane(), core.dual_station(s.stations.h, d), velocity=s.snapshot().velocity(),
                                moments=(s.target.Ph, s.target.Pv), measure=measure, **opts).value
              for d in (s.maps.d_ref, s.stations.d)]
    low, high = colour_range(*values)
    return [(v - low) / (high - low) for v in values]


def busy(events, last=False):
    """Whether Panel's busy indicator (``loading``: the css class pn-loading) is on a part of the
    page in ``events``: anywhere, or (``last``) still, after each model's last change of classes."""
    if not last:
        return any(attr == "css_classes" and LOADING in (new or []) for attr, _, new in events)
    final = {mid: new for attr, mid, new in events if attr == "css_classes"}
    return any(LOADING in (new or []) for new in final.values())


def received_images(client):
    return [np.asarray(m.data["image"][0], dtype=float) for m in client.doc.models
            if isinstance(m, ColumnDataSource) and m.name == "map-image"]


def open_calibration_tab(client):
    """Show the Calibration tab (as a click on it does); the tab's upload input, once drawn."""
    tabs = next(m for m in client.doc.models if type(m).__name__ == "Tabs")
    client._send(ModelChangedEvent(client.doc, tabs, "active", CALIBRATION_TAB))

    def upload():
        return next((m for m in client.doc.models
                     if "w-cal-upload" in (getattr(m, "css_classes", None) or [])), None)

    assert client._pump(lambda: upload() is not None, 60), "the Calibration tab was not drawn"
    return upload()


def test_an_uploaded_50000_reading_log_does_not_hold_up_another_session(server):
    uploader, other = on_thread(Client, server), on_thread(Client, server, B_ARGS)
    try:
        upload = open_calibration_tab(uploader)
        for attempt in range(3):  # the machine may be busy: the claim must hold in one clean try
            data = log_csv(seed=28 + attempt)  # a new log each time (the tab keeps its last result)
            assert data.count(b"\n") == READINGS + 1
            done, start = {}, len(uploader.events)

            def solved(events):
                return any(attr == "text" and isinstance(new, str) and f"({READINGS} attitudes" in new
                           for attr, _, new in events)

            def send_upload():
                # as the browser's FileDropper sends a file: in pieces, each an upload event
                t0 = time.perf_counter()
                first = len(uploader.events)
                step = UPLOAD_CHUNK_BYTES
                pieces = [data[i:i + step] for i in range(0, len(data), step)]
                for k, piece in enumerate(pieces, 1):
                    uploader._send(MessageSentEvent(uploader.doc, "bokeh_event", SentUpload(
                        upload, data=dict(name=f"log{attempt}.csv", chunk=k, total_chunks=len(pieces),
                                          type="text/csv", data=piece))))
                ok = uploader._pump(lambda: solved(uploader.events[first:]), 180)
                rtt = time.perf_counter() - t0 if ok else None
                done["end"] = t0 + rtt if rtt is not None else None
                done["time"] = rtt

            worker = threading.Thread(target=send_upload)
            sent = time.perf_counter()
            worker.start()
            # The server has the upload and computes it: A's page shows its busy indicator.
            deadline = time.perf_counter() + 30
            while time.perf_counter() < deadline and not busy(uploader.events[start:]):
                time.sleep(0.01)
            busy_seen = time.perf_counter() < deadline
            busy_after = time.perf_counter() - sent
            ph = 150.0 + attempt
            t0 = time.perf_counter()
            quick = other.change(other.ph, "value_throttled", ph, other.maps_done, timeout=60)
            quick_end = t0 + (quick or 0)
            worker.join(200)
            assert done.get("time") is not None, f"the {READINGS}-reading log was not solved in 180 s"
            assert busy_seen, "A's page never showed the busy indicator over the calibration's results"
            assert quick is not None, "B's slider change was not answered"
            # the indicator goes off with the result, in a message of its own right after it
            # (app/kit/offloop.py, changes): a few ms, 5 s allowed for a loaded machine
            uploader._pump(lambda: not busy(uploader.events[start:], last=True), 5)
            events = uploader.events[start:]
            assert not busy(events, last=True), "the busy indicator was left on after the result"
            print(f"attempt {attempt}: A's calibration {done['time']:.2f} s (busy after {busy_after:.2f} s), B's change {quick * 1e3:.0f} ms "
                  f"({'before' if quick_end < done['end'] else 'after'} A's result)")
            if quick < ANSWER_WITHIN and quick_end < done["end"]:
                break
        else:
            pytest.fail(f"B's slider change took {quick * 1e3:.0f} ms (bar {ANSWER_WITHIN * 1e3:.0f} ms) "
                        f"while A's {READINGS}-reading calibration took {done['time']:.1f} s; B answered "
                        f"{'before' if quick_end < done['end'] else 'after'} A's result")
        # B's maps are B's scenario's, to float32 precision of the normalised images (values of
        # order 1; the server's and this process's kernels agree to ~1e-12 in the values)
        got = received_images(other)
        for want in expected_images(ph):
            errs = [np.nanmax(np.abs(g - want)) if g.shape == want.shape
                    and np.array_equal(np.isnan(g), np.isnan(want)) else np.inf for g in got]
            assert min(errs) < 1e-5, f"no received map matches core's (largest differences {errs})"
        # and A's result is the log's: all 12 coefficients observable from 50,000 attitudes
        text = re.sub(r"<[^>]+>", "", html.unescape(" ".join(
            new for attr, _, new in events if attr == "text" and isinstance(new, str))))
        assert f"Rank of Γ: 12 of 12 ({READINGS} attitudes" in text, text[:500]
    finally:
        on_thread(close_client, uploader)
        on_thread(close_client, other)


def test_the_readme_the_container_and_the_cluster_serve_with_the_same_threads():
    """The README's serve command, the container's and app.serve.cluster's replicas pass the same
    ``--num-threads`` as the served app of these tests (support.server): one way of serving."""
    import inspect
    import json
    import shlex
    from pathlib import Path

    from app.serve import cluster

    root = Path(__file__).resolve().parents[1]

    def threads(args):
        args = list(args)
        return args[args.index("--num-threads") + 1] if "--num-threads" in args else None

    readme = next(line for line in (root / "README.md").read_text().splitlines()
                  if "panel serve app" in line and line.lstrip().startswith("python3 -m venv"))
    command = shlex.split(readme.split("&&")[-1])
    docker = (root / "Dockerfile").read_text()
    cmd = json.loads(docker[docker.index("\nCMD [") + 5:].split("]", 1)[0].replace("\\\n", "") + "]")
    served = inspect.getsource(__import__("support.server", fromlist=["served_app"]).served_app)
    assert threads(command) == threads(cmd) == str(cluster.Cluster(replicas=1).num_threads) == "4"
    assert '"--num-threads", "4"' in served
    # and all answer /liveness (issue 46 defect 13: the README's command had no --liveness)
    replica = inspect.getsource(cluster.Cluster._replica)
    assert "--liveness" in command and "--liveness" in cmd and '"--liveness"' in replica
    assert '"--liveness"' in served
    hosts = (root / "README.md").read_text().split("start `panel serve app", 1)[1].split("`")[0]
    assert "--liveness" in hosts, "the README's command for replicas on several hosts"
