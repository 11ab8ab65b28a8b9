"""Entry point for ``panel serve app``: build the page and serve it."""

import contextlib

import panel as pn

from app import server_threads
from app.dashboard import create_app, panel_extension

server_threads.configure()
panel_extension()
doc = pn.state.curdoc
# The template adds its ~15 roots one by one and Bokeh re-walks the whole model graph after each;
# frozen, it walks it once (a session took ~4 s to build on the event loop, ~2 s frozen).
with doc.models.freeze() if doc is not None else contextlib.nullcontext():
    create_app().servable(title="Dipole observability explorer")
