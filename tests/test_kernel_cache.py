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
