"""Keep numba's on-disk kernel cache in step with the kernels' sources.

Numba invalidates a cached kernel when *its own* source file changes (its documented rule: the
index is keyed by the file's modification time and size). Our cached kernels inline functions
and constants from other files (:mod:`core.kernels` inlines :mod:`core.fields` and
:mod:`core.sea`), so an edit to the physics in one file left kernels cached from another file
returning the old result until the cache files were deleted.

:func:`refresh` keys the whole cache by the sources instead: it hashes every file that holds
compiled kernels (:data:`KERNEL_SOURCES`, plus numba's version) and, when the hash differs
from the one recorded at the last refresh, touches each of those files (new modification
time), which numba's own rule then reads as "changed": every cached kernel recompiles on its
next call and rewrites its cache entry. Nothing is deleted. Importing this module calls it,
and ``core/__init__.py`` imports it first, before any kernel can run.

Where the sources cannot be touched (a read-only install, e.g. the container image, whose
sources never change after its build compiled the cache) it does nothing.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

#: Files of core/ that define or inline cached (``cache=True``) numba kernels. A module that
#: gains a cached kernel must be listed here (tests/test_kernel_cache.py checks the list).
KERNEL_SOURCES = ("fields.py", "sea.py", "kernels.py", "filters.py", "pcrlb.py",
                  "magnetic_kernels.py")
#: Name of the file that records the sources' hash at the last refresh.
STAMP = "kernel-sources.sha256"

_HERE = Path(__file__).resolve().parent


def sources_hash(root=_HERE):
    """SHA-256 (hex) of numba's version and the bytes of every :data:`KERNEL_SOURCES` file."""
    h = hashlib.sha256(numba.__version__.encode())
    for name in KERNEL_SOURCES:
        h.update(name.encode())
        h.update((Path(root) / name).read_bytes())
    return h.hexdigest()


def stamp_path(root=_HERE):
    """Where the hash is recorded: numba's cache directory if one is set (NUMBA_CACHE_DIR),
    else ``__pycache__`` beside the sources, as numba's own cache files."""
    base = Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else Path(root) / "__pycache__"
    if numba.config.CACHE_DIR:  # one stamp per source tree under a shared cache directory
        base = base / hashlib.sha256(str(Path(root)).encode()).hexdigest()[:16]
    return base / STAMP


def refresh(root=_HERE):
    """Invalidate numba's cache of every kernel if any kernel source changed since the last
    call (see module notes). Returns True if it invalidated."""
    digest = sources_hash(root)
    stamp = stamp_path(root)
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass  # no stamp yet (a fresh checkout): treat as changed
    try:
        for name in KERNEL_SOURCES:
            os.utime(Path(root) / name)  # numba's rule: a new mtime invalidates its cache
        stamp.parent.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False  # read-only sources: they cannot have changed since the cache was built
    return True


refresh()
