"""Benchmark of the Python one browser event costs the server, without the network.

    python -m bench.bench_events [--repeat 200]

Builds the dashboard in a document, as the server does for a session (after
``app.serve.threads.configure()``, as app/main.py), and times what runs when the P_h slider's
Bokeh model receives a release (``value_throttled``) that the Scenario refuses (P_h < 0): Panel's
slider, its editable twin, the link to the Scenario, the refusal and restore, the message. No map
is computed. The release is set on the Bokeh model with ``Model.set_from_json`` (as Bokeh applies
a browser's PATCH-DOC), which calls Panel's change handlers as a browser's message does (without
a session there is no 50 ms debounce and no worker thread: the Python only). Prints the median.
"""

from __future__ import annotations

import argparse
import statistics
import time

from bokeh.document import Document
from bokeh.models import Slider
from panel.io.state import set_curdoc

from app.page import create_app, panel_extension
from app.serve import threads as server_threads


def refused_release(repeat):
    """Seconds of each of ``repeat`` refused P_h releases."""
    server_threads.configure()
    panel_extension()
    doc = Document()
    with set_curdoc(doc):
        page = create_app()
        page.server_doc(doc)
        box = next(m for m in doc.select({"css_classes": ["w-Ph"]}))
        slider = box.select_one({"type": Slider})
        times = []
        for i in range(repeat):
            bad = -(i + 0.5)
            t0 = time.perf_counter()
            slider.set_from_json("value_throttled", bad)  # as Bokeh applies a browser message
            times.append(time.perf_counter() - t0)
            assert f"{bad:g}" in page.scenario.message, page.scenario.message  # it was refused
    return times


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200)
    args = parser.parse_args(argv)
    times = refused_release(args.repeat + 10)[10:]  # the first ten: warm-up
    print(f"refused P_h release, the server's Python: median {statistics.median(times) * 1e3:.2f} ms, "
          f"p95 {sorted(times)[int(0.95 * len(times))] * 1e3:.2f} ms (n={len(times)})")


if __name__ == "__main__":
    main()
