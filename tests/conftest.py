import ast
import functools
from pathlib import Path

import numpy as np
import pytest

from support.page import chromium_browser, open_page, wait_maps
from support.server import served_app

# The paper's common parameters (spec §5).
PAPER_STATE = np.array([30.0, 40.0, 120.0, 2.0, 2.0, 100.0, 20.0])


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


def random_states(rng, n, stations):
    """n random valid states, every target ≥ 5 m from every station."""
    out = []
    while len(out) < n:
        pos = rng.uniform([-300, -300, 0], [300, 300, 400])
        if np.min(np.linalg.norm(np.asarray(stations) - pos, axis=1)) < 5:
            continue
        vel = rng.uniform(-4, 4, 2)
        if np.hypot(*vel) < 0.2:
            continue
        out.append(np.r_[pos, vel, rng.uniform(-200, 200, 2)])
    return np.array(out)


def random_stations(rng, n_stations):
    return rng.uniform([-50, -50, 80], [50, 50, 120], (n_stations, 3))


# --------------------------------------------------------------------------- markers by file
#: A test file gets a marker from what it imports (so a new file is marked without a list to
#: keep): ``browser`` if it imports support.page (it drives Chromium), ``server`` if it imports
#: support.server (it serves the dashboard in a process of its own), both for support.screenshots. ``container`` is declared
#: by the file itself (tests/test_container.py). The fast lane leaves all three out:
#:     pytest -q -m "not browser and not server and not container"
MARKERS_OF_MODULE = {"support.page": {"browser"}, "support.server": {"server"},
                     "support.screenshots": {"browser", "server"}}
#: A test gets them from the fixtures below it uses, too (a file may use them without importing
#: support.page or support.server itself).
MARKERS_OF_FIXTURE = {"chromium": {"browser"}, "server": {"server"}, "page": {"browser", "server"}}


@functools.lru_cache(maxsize=None)
def markers_of_file(path):
    """The markers a test file gets from the support modules it imports (at any depth)."""
    tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "support":
            names = [f"support.{a.name}" for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            found |= MARKERS_OF_MODULE.get(name, set())
    return frozenset(found)


def pytest_collection_modifyitems(config, items):
    for item in items:
        used = getattr(item, "fixturenames", ())
        by_fixture = set().union(*(MARKERS_OF_FIXTURE.get(f, set()) for f in used))
        for name in sorted(markers_of_file(str(item.path)) | by_fixture):
            item.add_marker(name)
        # ``serial``: a file that measures time, threads or memory of a server, or runs processes
        # that must not share the machine with another worker, says so with ``SERIAL = "why"``.
        # The rest can run on two workers (``pytest -n 2 --dist loadfile -m "not serial"``), then
        # ``pytest -m serial`` alone (docs/architecture.md, Testing).
        if getattr(item.module, "SERIAL", None):
            item.add_marker("serial")


# --------------------------------------------------------------------------- served and driven
# One served dashboard and one Chromium per test file (module scope: a page per test is cheap,
# a server's start and warm-up are not). A file that needs another server (a log, a longer
# warm-up, its own URL) defines its own ``server``.

@pytest.fixture(scope="module")
def server():
    """The dashboard served on a free loopback port (support.server): its base URL."""
    with served_app() as (url, _):
        yield url


@pytest.fixture(scope="module")
def chromium():
    """Debian's headless Chromium (support.page)."""
    with chromium_browser() as browser:
        yield browser


@pytest.fixture
def page(chromium, server):
    """The dashboard's page with its three maps drawn; the test fails on any console error,
    uncaught error or failed request of the page."""
    errors = []
    pg = open_page(chromium, server + "/app", errors, requests=True)
    wait_maps(pg, lambda maps: len(maps) == 3)
    yield pg
    pg.close()
    assert errors == [], f"browser console errors: {errors}"
