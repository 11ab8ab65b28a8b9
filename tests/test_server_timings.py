"""The served app's per-update timings (app/kit/timings.py, issue 40): with ``APP_TIMINGS`` set, an
update of the maps is recorded with a timestamp for every leg, in order, matched to the session
and the value that made it. Structural only (which legs, in which order, on one clock with the
client's); the durations are bench/load_test.py's business."""

import os
import time

import pytest

from app.kit import timings
from bench.load_test import Client
from support.server import close_client, on_thread, served_app

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it reads the per-update timings of a served session"


@pytest.fixture(scope="module")
def timed_server(tmp_path_factory):
    path = tmp_path_factory.mktemp("timings") / "updates.jsonl"
    os.environ.setdefault("QUIET_SERVER", "1")
    before = os.environ.get(timings.ENV)
    os.environ[timings.ENV] = str(path)  # the server process's environment (support.server)
    try:
        with served_app() as (url, _):
            yield url, path
    finally:
        if before is None:
            os.environ.pop(timings.ENV, None)
        else:
            os.environ[timings.ENV] = before


def test_every_leg_of_an_update_is_recorded_in_order(timed_server):
    url, path = timed_server
    client = on_thread(Client, url)
    try:
        sent_at = []
        for value in (123.45, 234.56):
            t0 = time.perf_counter()  # CLOCK_MONOTONIC: the server's clock too
            rtt = client.change(client.ph, "value_throttled", value, client.maps_done)
            assert rtt is not None, f"P_h = {value} was not answered"
            sent_at.append((value, t0, t0 + rtt))
        measure = "CRLB position error (m)"
        assert client.change(client.measure, "value", measure, client.maps_done) is not None
    finally:
        on_thread(close_client, client)
    records = [r for r in timings.read(path) if r["session"] == client.session.id]
    for value, t0, t1 in sent_at:
        rec = [r for r in records if r["changed"] == {"Ph": value}]
        assert len(rec) == 1, (value, records)
        rec = rec[0]
        assert rec["outcome"] == "sent" and rec["pid"] > 0
        stamps = [rec[leg] for leg in timings.LEGS]  # every leg there (a KeyError otherwise)
        assert stamps == sorted(stamps), {leg: rec[leg] - rec["handler"] for leg in timings.LEGS}
        # one clock with the client's: the change arrived after it was sent, and the patch was
        # written before the client had it
        assert t0 <= rec["arrived"] and rec["sent"] <= t1
    assert any(r["changed"] == {"measure": measure} and r["outcome"] == "sent" for r in records)

