"""The page a session gets while the server is still compiling the kernels the maps need
(first start after install or after an edit of a kernel): what is happening and for how long,
updated every second; it reloads itself, keeping its address, when the maps can be computed."""

from __future__ import annotations

import panel as pn

from .warmup import WARMUP

#: Seconds between updates of the warming-up page.
POLL_S = 1.0

INTRO = """
## Dipole observability explorer: the server is warming up

This is the first start since the tool was installed (or its kernels were edited): the server is
compiling the numerical kernels the maps need, which takes a few minutes on a 2-core machine and
happens once; later starts load them from the cache in about a second. **This page reloads
itself, with the same address, as soon as the maps can be computed** — there is nothing to do.
"""


def warming_page(warmup=WARMUP):
    """A small page with the warm-up's progress; reloads the browser when stage 0 is ready."""
    status = pn.pane.Markdown(warmup.status(), css_classes=["warmup-status"])
    spinner = pn.indicators.LoadingSpinner(value=True, size=40)
    page = pn.Column(pn.pane.Markdown(INTRO), pn.Row(spinner, status), margin=(20, 40),
                     css_classes=["warming-page"])

    def poll():
        status.object = warmup.status()
        if warmup.ready(0):
            callback.stop()
            status.object = "The maps' kernels are ready: loading the dashboard…"
            pn.state.location.reload = True  # Panel's Location reloads the page, same address

    callback = pn.state.add_periodic_callback(poll, period=int(POLL_S * 1000))
    return page
