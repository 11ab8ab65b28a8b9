"""Entry point for ``panel serve app``: build the page and serve it."""

import sys

import panel as pn

from app.dashboard import create_app

#: A map is computed on a worker thread while the event loop's thread runs Panel's Python; the
#: worker gives up the GIL in every numpy/numba call and, by default, may then wait 5 ms to get
#: it back each time. 0.5 ms lets it resume promptly.
sys.setswitchinterval(0.0005)

pn.extension("tabulator", throttled=True, loading_indicator=True, notifications=False)
create_app().servable(title="Dipole observability explorer")
