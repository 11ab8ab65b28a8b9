"""The page a session gets while the server is still compiling the kernels the maps need
(first start after install or after an edit of a kernel): what is happening and for how long,
updated every second; it reloads itself, keeping its address, when the maps can be computed.

The reload is race-free by construction: it is asked for only once the page has told the server
it is up (``pn.state.onload``, run when the browser reports the document rendered), and then as
soon as the kernels are ready. Asked for earlier, from the periodic callback alone, a reload set
before the browser had connected arrived as the page's initial state, which the browser does not
act on (it reloads on a *change*): a page opened as the warm-up ended stood on "loading the
dashboard…" for good.
"""

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

    loaded, sent = [False], [False]
    location = pn.state.location

    def reload_when_ready():
        if loaded[0] and warmup.ready(0) and not sent[0]:
            sent[0] = True
            callback.stop()
            status.object = "The maps' kernels are ready: loading the dashboard…"
            location.reload = True  # Panel's Location reloads the page, same address

    def poll():
        if not sent[0]:
            status.object = warmup.status()
        reload_when_ready()

    def page_up():  # the browser has rendered the page: a change of ``reload`` now reaches it
        loaded[0] = True
        reload_when_ready()

    callback = pn.state.add_periodic_callback(poll, period=int(POLL_S * 1000))
    pn.state.onload(page_up)
    return page
