"""The served app's kernel threads sleep between parallel regions (app/__init__.py): GNU
OpenMP's default spin after each region took ~3 ms of CPU per default update from the event loop
on two cores. Checked in fresh processes, since libgomp reads the setting once, when numba first
loads its threading layer."""

import os
import subprocess
import sys

from support import ROOT

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it measures the CPU an idle OpenMP pool burns"

PROBE = """
import os
import app.tabs.maps.compute as c
from app.state.scenario import Scenario
c.compute(c.Snapshot.of(Scenario()))  # runs the parallel kernels: the threading layer is loaded
import numba
print(numba.threading_layer(), os.environ.get("OMP_WAIT_POLICY"))
"""


def _probe(**env):
    base = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, env={**base, "PYTHONPATH": str(ROOT), **env},
                         capture_output=True, text=True, timeout=300, check=True)
    return out.stdout.split()


def test_the_app_sets_passive_waiting_before_the_kernels_load_their_threads():
    layer, policy = _probe()
    assert policy == "passive"
    assert layer == "omp"  # the setting is GNU OpenMP's: with another layer it would do nothing


def test_a_users_own_setting_is_kept():
    assert _probe(OMP_WAIT_POLICY="active")[1] == "active"
