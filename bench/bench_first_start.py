"""Cold start of the README's serve command (issue 29): packages installed, no compiled kernels.

    python -m bench.bench_first_start [--runs 1]

Starts ``panel serve app`` with an empty ``NUMBA_CACHE_DIR`` (numba then compiles every kernel,
exactly as on a fresh checkout), opens ``/app`` in Debian's headless Chromium at once, and times,
from the command's start:

* ``answers``: ``/app`` returns a page (the warming-up page on a cold start);
* ``maps ready``: the server's terminal says the default page's kernels are compiled;
* ``maps drawn``: the page has reloaded itself into the dashboard and three maps are drawn;
* ``all kernels``: the last stage of the warm-up (layered sea, CRLB, tracking) is done.

Targets (issue 29): answers ≤ 15 s, first maps drawn ≤ 120 s (aim 60 s). The figures depend on
what else runs on the machine: say so when reporting them.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from support.page import chromium_browser
from support.server import ROOT, SERVER_ENV, free_port
from support.page import wait_maps

READY_0 = re.compile(r"\[warm-up\] 1/\d+: .* ready in")
ALL = "[warm-up] all kernels ready"


def one_run():
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory(prefix="cold-start-") as tmp:
        log = Path(tmp) / "server.log"
        env = {**os.environ, **SERVER_ENV, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba")}
        cmd = [sys.executable, "-m", "panel", "serve", "app", "--port", str(port), "--address",
               "127.0.0.1", "--allow-websocket-origin", f"127.0.0.1:{port}", "--num-threads", "4"]
        t0 = time.monotonic()
        with open(log, "w") as fh:
            proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT, env=env)
        times = {}
        try:
            while "answers" not in times:
                try:
                    with urllib.request.urlopen(url + "/app", timeout=5) as reply:
                        reply.read()
                    times["answers"] = time.monotonic() - t0
                except OSError:
                    time.sleep(0.1)
            with chromium_browser() as browser:
                page = browser.new_page(viewport={"width": 1600, "height": 1000})
                page.goto(url + "/app", timeout=60_000)
                deadline = t0 + 900
                while "maps drawn" not in times and time.monotonic() < deadline:
                    text = log.read_text(errors="replace")
                    if "maps ready" not in times and READY_0.search(text):
                        times["maps ready"] = time.monotonic() - t0
                    try:
                        wait_maps(page, lambda drawn: len(drawn) == 3, timeout=1.0)
                        times["maps drawn"] = time.monotonic() - t0
                    except Exception:  # noqa: BLE001 (not yet: the warming page, or a reload)
                        pass
                page.close()
            while ALL not in log.read_text(errors="replace") and time.monotonic() < t0 + 900:
                time.sleep(0.5)
            times["all kernels"] = time.monotonic() - t0
        finally:
            proc.terminate()
            proc.wait(30)
    return times


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1, help="cold starts to time (each ~2-4 min)")
    args = ap.parse_args(argv)
    for k in range(args.runs):
        times = one_run()
        print(f"run {k + 1}: " + ", ".join(f"{name} {s:.1f} s" for name, s in times.items()),
              flush=True)


if __name__ == "__main__":
    main()
