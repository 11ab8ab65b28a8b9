"""Lifecycle hooks of the ``panel serve app`` directory application (Bokeh's DirectoryHandler
calls ``on_server_loaded`` once, when the server loads the app and before it serves a session)."""

from app.page import freeze_startup_objects
from app.serve.warmup import WARMUP


def on_server_loaded(server_context):
    """Start compiling the numba kernels on a background thread and serve at once: until the
    default page's kernels are ready a session gets the warming-up page (app/serve/warming.py)."""
    WARMUP.start()
    freeze_startup_objects()  # the app is imported: no full collection walks it again
