"""Process-wide serving settings (app/serve/threads.py)."""

import sys

from app.serve import threads as server_threads

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it counts the threads of the serving process"


def test_switch_interval_is_short():
    before = sys.getswitchinterval()
    try:
        server_threads.configure()
        assert sys.getswitchinterval() == server_threads.SWITCH_INTERVAL <= 0.001
    finally:
        sys.setswitchinterval(before)
