"""The layout of core/ by role (issue 26): no import circle, a compiled-kernel leaf, and
argparse, matplotlib and tqdm imported only by the command-line tools.

Every import statement of every module under core/ is read with ``ast`` (at any depth: an
import inside a function counts as much as one at the top) and resolved to the core modules it
names; a package's ``__init__`` counts as imported only where it is named (``from . import x``
names ``x``; ``from .pkg import name`` names ``pkg``, and ``pkg.name`` where that is a module).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import core

CORE = Path(core.__file__).resolve().parent

#: Modules that may import argparse, matplotlib or tqdm: the command-line tools and their
#: ``python -m`` entry points.
CLI = ("core.cli", "core.sweep.__main__", "core.track", "core.calibration.__main__", "core.shape.__main__")
CLI_ONLY = ("argparse", "matplotlib", "tqdm")


def _modules():
    """{dotted name: path} of every module under core/ (a package as its __init__)."""
    out = {}
    for path in CORE.rglob("*.py"):
        parts = list(path.relative_to(CORE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _imports(name, path):
    """(core modules, top-level outside packages) that module ``name`` imports."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rpartition(".")[0]
    inner, outer = set(), set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            # ``from pkg import x`` names the module pkg.x where there is one, else pkg
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in MODULES else mod
                       for a in node.names]
        else:
            continue
        for t in targets:
            if t.split(".")[0] == "core":
                if t in MODULES:
                    inner.add(t)
            else:
                outer.add(t.split(".")[0])
    inner.discard(name)
    return inner, outer


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _cycles():
    """Every import circle among core's modules (Tarjan's strongly connected components)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(GRAPH[v][0]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    return found


def test_the_graph_is_read():
    """The reader sees today's known edges (so that an empty result below means something)."""
    assert "core.kernels.electric" in GRAPH["core.kernels.gamma"][0]
    assert "core.kernels.gamma" in GRAPH["core.model.fields"][0]
    assert "core.model.validation" in GRAPH["core.tracking.motion"][0]
    assert "core.cli.sweep" in GRAPH["core.sweep.__main__"][0]
    assert "core.sweep" in GRAPH["core.cli.sweep"][0]  # the engine, out of the CLI
    assert "argparse" in GRAPH["core.cli"][1] and "tqdm" in GRAPH["core.cli.sweep"][1]


def test_no_import_circle_in_core():
    assert _cycles() == []


def test_the_cycle_finder_finds_one():
    """The same finder on a graph with a circle (fields ↔ sea ↔ kernels, as core had)."""
    saved = dict(GRAPH)
    try:
        GRAPH["core.kernels.electric"] = (GRAPH["core.kernels.electric"][0] | {"core.model.sea"},
                                          GRAPH["core.kernels.electric"][1])
        assert any("core.kernels.electric" in c and "core.model.sea" in c for c in _cycles())
    finally:
        GRAPH.clear()
        GRAPH.update(saved)


@pytest.mark.parametrize("name", sorted(n for n in MODULES if n.startswith("core.kernels")))
def test_the_kernels_are_a_leaf(name):
    """core.kernels imports nothing of core outside itself, and only math, numpy and numba."""
    inner, outer = GRAPH[name]
    assert all(m.startswith("core.kernels") for m in inner), inner
    assert outer <= {"__future__", "math", "numpy", "numba"}, outer


def test_every_compiled_kernel_is_in_the_leaf():
    decorator = re.compile(r"^\s*@(nb\.|numba\.)?(njit|jit|vectorize|guvectorize)\b", re.M)
    jitted = {n for n, p in MODULES.items() if decorator.search(p.read_text())}
    assert jitted and all(n.startswith("core.kernels.") for n in jitted), jitted


@pytest.mark.parametrize("lib", CLI_ONLY)
def test_cli_libraries_only_in_the_cli(lib):
    users = {n for n, (_, outer) in GRAPH.items() if lib in outer}
    assert users, f"no module imports {lib}: the check would pass whatever the layout"
    stray = {n for n in users if not any(n == c or n.startswith(c + ".") for c in CLI)}
    assert stray == set()


#: Issue 39: no module of core/ longer than this (a longer one is split by role).
MAX_MODULE_LINES = 500


def test_no_core_module_over_500_lines():
    long = {name: n for name, path in MODULES.items()
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert long == {}
