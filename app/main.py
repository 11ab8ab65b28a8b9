"""Entry point for ``panel serve app``: build the page and serve it."""

import panel as pn

from app import server_threads
from app.dashboard import create_app

server_threads.configure()
pn.extension("tabulator", throttled=True, loading_indicator=True, notifications=False)
create_app().servable(title="Dipole observability explorer")
