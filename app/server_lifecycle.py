"""Lifecycle hooks of the ``panel serve app`` directory application (Bokeh's DirectoryHandler
calls ``on_server_loaded`` once, when the server loads the app and before it serves a session)."""

import logging

from app.warmup import compile_kernels


def on_server_loaded(server_context):
    """Compile the numba kernels now, so that the first visitor does not wait for LLVM."""
    logging.getLogger(__name__).info("numba kernels ready in %.1f s", compile_kernels())
