"""numba's on-disk cache cannot go stale (core.kernel_cache).

The bug it fixes: a cached kernel in core/kernels/gamma.py inlines the field of
core/kernels/electric.py, and numba checks only the kernel's own file, so editing the physics in
electric.py left
core.dipole_field returning the old field until the cache files were deleted by hand. Here a
copy of core/ is edited the same way and run in fresh interpreters, nothing deleted by hand:
core.kernel_cache sees the sources' hash change and drops the stale cache itself.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import core
from core import kernel_cache

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it edits and recompiles kernels of a copy of core/ and reads the install's cache"

CORE = Path(core.__file__).resolve().parent

PROBE = (
    "import core; "
    "print(repr(float(core.dipole_field([0, 0, 0, 1, 0, 100, 0], [[10, 0, 0]], sigma=1.0)[0, 0])))"
)


def test_every_cached_kernel_source_is_listed():
    cached = {p.relative_to(CORE).as_posix() for p in CORE.rglob("*.py")
              if re.search(r"cache=True|\*\*JIT\)", p.read_text())} - {"kernel_cache.py"}
    assert cached == set(kernel_cache.KERNEL_SOURCES)


def test_refresh_removes_the_kernels_cache_only_when_a_source_changes(tmp_path, monkeypatch):
    monkeypatch.setattr(kernel_cache.numba.config, "CACHE_DIR", "")
    for name in kernel_cache.KERNEL_SOURCES:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(f"# {name}\n")
    cache = tmp_path / "kernels" / "__pycache__"
    cache.mkdir()
    stale = [cache / "gamma.fill_gamma-122.py311.nbi", cache / "sea.pair_rows-346.py311.1.nbc"]
    other = cache / "grids.cpython-311.pyc"
    for p in (*stale, other):
        p.write_bytes(b"x")
    assert kernel_cache.refresh(tmp_path)  # no stamp yet: caches of unknown sources go
    assert not any(p.exists() for p in stale) and other.exists()
    for p in stale:
        p.write_bytes(b"x")
    assert not kernel_cache.refresh(tmp_path)  # same sources: the cache stays
    assert all(p.exists() for p in stale)
    (tmp_path / "kernels" / "electric.py").write_text("# electric.py, edited\n")
    assert kernel_cache.refresh(tmp_path)  # one source edited: every kernel's cache goes
    assert not any(p.exists() for p in stale) and other.exists()


def _run(root):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(root)
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=root, env=env, capture_output=True,
                         text=True, timeout=900, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def _cache_files(root):
    return {p.relative_to(root) for p in (root / "core").rglob("*") if p.suffix in (".nbi", ".nbc")}


def test_an_edit_to_inlined_physics_reaches_the_cached_kernel(tmp_path):
    shutil.copytree(CORE, tmp_path / "core")  # with its caches (copy2 keeps their stamps)
    before = _run(tmp_path)
    # the exact on-axis field 2 p / (4πσD³): 100 A·m at 10 m, σ = 1
    assert before == pytest.approx(2 * 100 / (4 * 3.141592653589793 * 1000), rel=1e-12)
    caches = _cache_files(tmp_path)
    assert caches  # the first run cached its kernels
    # the edit: E_x's 3 (p·r) r_x term doubled, in electric.py (inlined by gamma.py's kernel)
    fields = tmp_path / "core" / "kernels" / "electric.py"
    text = fields.read_text()
    old = "return (3.0 * a * f - ph * cos * s[0],"
    assert text.count(old) == 1
    fields.write_text(text.replace(old, "return (6.0 * a * f - ph * cos * s[0],"))
    after = _run(tmp_path)
    # on the axis 3 (p·r) r_x / D⁵ = 3 p / D³, so E_x = (3 − 1) p w / D³ becomes (6 − 1) p w / D³
    assert after == pytest.approx(2.5 * before, rel=1e-12)
    assert _cache_files(tmp_path)  # the new kernels cached themselves
    assert _run(tmp_path) == after  # and the next interpreter loads them


def _fake_tree(root):
    for name in kernel_cache.KERNEL_SOURCES:  # a kernel numba caches on its own, in each
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(f"# {name}\n@nb.njit(cache=True)\ndef kernel(x):\n    return x\n")
    cache = root / "kernels" / "__pycache__"
    cache.mkdir()
    files = []
    for name in kernel_cache.KERNEL_SOURCES:
        stem = Path(name).stem
        files += [cache / f"{stem}.kernel-1.py311.nbi", cache / f"{stem}.kernel-1.py311.1.nbc"]
    for p in files:
        p.write_bytes(b"x")
    return files


def test_a_new_numba_cache_dir_leaves_the_installs_compiled_kernels_alone(tmp_path, monkeypatch):
    # issue 40 defect 15: a process started with a new NUMBA_CACHE_DIR found no stamp there and
    # removed every cache it could find, core/kernels/__pycache__ included
    tree = tmp_path / "core"
    files = _fake_tree(tree)
    monkeypatch.setattr(kernel_cache.numba.config, "CACHE_DIR", "")
    kernel_cache.refresh(tree)  # the install's own start: its stamp, its cache
    for p in files:
        p.write_bytes(b"x")
    assert not kernel_cache.refresh(tree) and kernel_cache.cached(tree)
    elsewhere = tmp_path / "numba-cache"
    monkeypatch.setattr(kernel_cache.numba.config, "CACHE_DIR", str(elsewhere))
    kernel_cache.refresh(tree)  # a process with a cache directory of its own
    assert all(p.exists() for p in files)
    assert not kernel_cache.cached(tree)  # that process's cache is empty: it will compile
    monkeypatch.setattr(kernel_cache.numba.config, "CACHE_DIR", "")
    assert not kernel_cache.refresh(tree) and kernel_cache.cached(tree)  # the next ordinary start loads


def test_cached_needs_every_kernel_module(tmp_path, monkeypatch):
    monkeypatch.setattr(kernel_cache.numba.config, "CACHE_DIR", "")
    files = _fake_tree(tmp_path)
    assert kernel_cache.cached(tmp_path)
    files[0].unlink()  # one module's index gone: that module compiles, "loading" would be untrue
    assert not kernel_cache.cached(tmp_path)


def test_a_module_of_inlined_kernels_only_is_not_asked_for_an_index(tmp_path, monkeypatch):
    # issue 46 defect 11: core/kernels/electric.py's kernels are all inline="always": numba never
    # writes an index for it, so cached() was never true and every warm start said "compiling"
    monkeypatch.setattr(kernel_cache.numba.config, "CACHE_DIR", "")
    files = _fake_tree(tmp_path)
    electric = tmp_path / "kernels" / "electric.py"
    electric.write_text('@nb.njit(inline="always", **JIT)\ndef f(x):\n    return x\n')
    for p in files:
        if p.name.startswith("electric."):
            p.unlink()
    assert kernel_cache.cached(tmp_path)
    assert not kernel_cache.writes_cache(CORE / "kernels" / "electric.py")  # the real one too
    assert all(kernel_cache.writes_cache(CORE / name) for name in kernel_cache.KERNEL_SOURCES
               if not name.endswith("electric.py"))


def test_the_install_s_cache_after_a_warm_up_counts_as_cached():
    """Once every stage of the warm-up has run (minutes when the cache is cold, a second when
    it is filled: the suite's served apps have run it), the next start says it loads."""
    import io

    from app.serve.warmup import compile_kernels

    compile_kernels(out=io.StringIO())
    assert kernel_cache.cached()


def test_a_process_with_a_new_cache_dir_keeps_a_trees_kernels(tmp_path):
    # the same in real interpreters: `import core` with NUMBA_CACHE_DIR set, on a copy of core/
    # whose cache is current (its stamp written by an ordinary start)
    shutil.copytree(CORE, tmp_path / "core")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(tmp_path)
    subprocess.run([sys.executable, "-c", "import core"], cwd=tmp_path, env=env, check=True, timeout=300)
    marker = tmp_path / "core" / "kernels" / "__pycache__" / "gamma.marker-1.py311.nbi"
    marker.write_bytes(b"x")  # stands for a compiled kernel of the current sources
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "new-cache")
    subprocess.run([sys.executable, "-c", "import core"], cwd=tmp_path, env=env, check=True, timeout=300)
    assert marker.exists()
