"""Entry point for ``panel serve app``: build the page and serve it (or, while the kernels of the
default page are still compiling on a first start, a page that says so: app/serve/warming.py)."""

import contextlib

import panel as pn

from app.kit.connection import watch_connection
from app.page import create_app, freeze_startup_objects, panel_extension
from app.serve import threads as server_threads
from app.serve.warming import warming_page
from app.serve.warmup import WARMING_MARK, WARMUP

server_threads.configure()
panel_extension()
#: Seconds the first session of a process waits for the default page's kernels when nothing
#: started the warm-up before it (``panel serve app/main.py``, as the container does: its image
#: holds the compiled kernels, so they load in about a second and nobody sees the warming page).
FIRST_SESSION_WAIT = 5.0

if WARMUP.start():  # False when app/server_lifecycle.py started it (``panel serve app``)
    freeze_startup_objects()
    WARMUP.done[0].wait(FIRST_SESSION_WAIT)
watch_connection(pn.state.curdoc)  # a page whose server goes away says so (app/kit/connection.py)
if not WARMUP.ready(0):
    warming_page().servable(title=WARMING_MARK)
else:
    doc = pn.state.curdoc
    # The template adds its ~15 roots one by one and Bokeh re-walks the whole model graph after
    # each; frozen, it walks it once (a session took ~4 s to build on the event loop, ~2 s frozen).
    with doc.models.freeze() if doc is not None else contextlib.nullcontext():
        create_app().servable(title="Dipole observability explorer")
