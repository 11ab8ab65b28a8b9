"""Keep numba's on-disk kernel cache in step with the kernels' sources (docs/measurement-model.md,
*A kernel cache that cannot go stale*).

numba reuses a cached kernel while its own source file is unchanged, but our kernels inline code
from other files. :func:`refresh` hashes every file that holds compiled kernels
(:data:`KERNEL_SOURCES`, plus numba's version) and, when the hash differs from the one recorded
at the last refresh, removes those modules' cache files (``*.nbi``, ``*.nbc``), so that every
kernel recompiles on its next call. Importing this module calls it; ``core/__init__.py`` imports
it first, before any kernel is decorated. Where the cache cannot be written (a read-only
install) it does nothing. A stamp speaks for the one cache location numba uses in this process
(``__pycache__`` beside the sources, or ``NUMBA_CACHE_DIR``): a process with a new
``NUMBA_CACHE_DIR`` never removes the install's own compiled kernels.
"""

from __future__ import annotations

import ast
import hashlib
from pathlib import Path

import numba

#: Files of core/ (paths relative to it) that define or inline cached (``cache=True``) numba
#: kernels. A module that gains a cached kernel must be listed here (tests/test_kernel_cache.py
#: checks the list against every file under core/, subpackages included).
KERNEL_SOURCES = ("kernels/electric.py", "kernels/sea.py", "kernels/gamma.py", "kernels/measures.py",
                  "kernels/filters.py", "kernels/pcrlb.py", "kernels/magnetic.py", "kernels/loss.py")
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


def cache_dirs(root=_HERE):
    """Where numba caches the kernels in this process: NUMBA_CACHE_DIR when set, else the
    ``__pycache__`` directories beside the :data:`KERNEL_SOURCES`."""
    if numba.config.CACHE_DIR:
        return [Path(numba.config.CACHE_DIR)]
    return sorted({(Path(root) / name).parent / "__pycache__" for name in KERNEL_SOURCES})


def cache_files(root=_HERE):
    """numba's cache files of the :data:`KERNEL_SOURCES` modules in :func:`cache_dirs` (anywhere
    under NUMBA_CACHE_DIR, when set)."""
    stems = [Path(name).stem for name in KERNEL_SOURCES]
    dirs = cache_dirs(root)
    found = []
    for d in dirs:
        if d.is_dir():
            for stem in stems:
                found += [p for p in d.rglob(f"{stem}.*") if p.suffix in (".nbi", ".nbc")]
    return found


def _inlined(decorator):
    """Whether a decorator is numba's ``njit``/``jit`` with ``inline="always"``."""
    return isinstance(decorator, ast.Call) and any(
        k.arg == "inline" and isinstance(k.value, ast.Constant) and k.value.value == "always"
        for k in decorator.keywords)


def writes_cache(path):
    """Whether numba writes cache files for the module at ``path``: it has a jitted function
    that is not ``inline="always"``. An inlined kernel is compiled into its callers and cached
    with them; core/kernels/electric.py holds only such kernels, so it never has an index."""
    tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            for d in node.decorator_list:
                name = d.func if isinstance(d, ast.Call) else d
                name = name.attr if isinstance(name, ast.Attribute) else getattr(name, "id", "")
                if name in ("njit", "jit") and not _inlined(d):
                    return True
    return False


def cached(root=_HERE):
    """Whether every :data:`KERNEL_SOURCES` module that numba writes cache files for
    (:func:`writes_cache`) has compiled kernels (an index, ``*.nbi``) in the cache this process
    reads: what a start may honestly call "loading from the cache". (Asking the same of a module
    of inlined kernels only made every warm start say it was compiling: issue 46 defect 11.)"""
    have = {p.name.split(".")[0] for p in cache_files(root) if p.suffix == ".nbi"}
    return have >= {Path(name).stem for name in KERNEL_SOURCES if writes_cache(Path(root) / name)}


def refresh(root=_HERE):
    """Remove numba's cache of every kernel if any kernel source changed since the last call
    (see module notes). Returns True if it did."""
    digest = sources_hash(root)
    stamp = stamp_path(root)
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass  # no stamp yet (a fresh checkout): any cache there is of unknown sources
    try:  # the stamp first: where it cannot be written, nothing is removed
        stamp.parent.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False  # a read-only cache: its sources cannot have changed since it was built
    for path in cache_files(root):
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass  # another user's file in a shared NUMBA_CACHE_DIR: left as it is
    return True


refresh()
