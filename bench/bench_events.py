"""Benchmark of the Python one browser event costs the server, without the network.

    python -m bench.bench_events [--repeat 200]

Builds the dashboard in a document, as the server does for a session, and times what Panel runs
on a worker thread when a P_h slider release arrives that the Scenario refuses (P_h < 0): the
slider, its editable twin, the link to the Scenario, the refusal and restore, the message.
No map is computed. Timed with param's own ``Parameters.update`` and with the one
``app.server_threads`` installs (``update_reads_only_what_it_sets``), in alternating blocks in
this run; prints the medians and their ratio.
"""

from __future__ import annotations

import argparse
import statistics
import time

import panel as pn
from bokeh.document import Document
from panel.io.state import set_curdoc
from param.parameterized import Parameters

from app import server_threads
from app.dashboard import TypedFloatSlider, create_app


def refused_release(repeat):
    """Seconds of each of ``repeat`` refused P_h releases, alternating param's update and ours."""
    server_threads.configure()
    pn.extension("tabulator", throttled=True, loading_indicator=True, notifications=False)
    doc = Document()
    updates = {"param's own": server_threads._PARAM_UPDATE, "reads only what it sets": server_threads._update}
    times = {kind: [] for kind in updates}
    with set_curdoc(doc):
        page = create_app()
        page.server_doc(doc)
        slider = next(w for w in page.select(TypedFloatSlider) if "w-Ph" in w.css_classes)._slider
        try:
            for i in range(repeat):
                kind = list(updates)[(i // 10) % 2]  # blocks of ten, alternating
                Parameters._update = updates[kind]
                bad = -(i + 0.5)
                t0 = time.perf_counter()
                slider._process_events({"value_throttled": bad})
                times[kind].append(time.perf_counter() - t0)
                assert f"{bad:g}" in page.scenario.message, page.scenario.message  # it was refused
        finally:
            Parameters._update = server_threads._update
    return times


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200)
    args = parser.parse_args(argv)
    times = refused_release(args.repeat + 20)
    medians = {kind: statistics.median(t[10:]) for kind, t in times.items()}  # first block: warm-up
    for kind, m in medians.items():
        print(f"refused P_h release, Panel's worker-thread Python, {kind:>24}: median {m * 1e3:.2f} ms "
              f"(n={len(times[kind]) - 10})")
    own, ours = medians.values()
    print(f"ratio: {own / ours:.2f}× (param's own / reads only what it sets)")


if __name__ == "__main__":
    main()
