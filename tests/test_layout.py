"""The layout of core/ and app/ by role (issues 26, 47).

core/: no import circle, a compiled-kernel leaf, and argparse, matplotlib and tqdm imported only
by the command-line tools. app/: no import circle, no project import inside a function, a tab
imports no other tab, the state imports no web library, no function over 80 lines.

Every import statement of every module is read with ``ast`` by :mod:`support.imports` (at any
depth: an import inside a function counts as much as one at the top) and resolved to the
package's modules it names; a package's ``__init__`` counts as imported only where it is named
(``from . import x`` names ``x``; ``from .pkg import name`` names ``pkg``, and ``pkg.name`` where
that is a module).
"""

from __future__ import annotations

import re

import pytest

from support import imports

#: Modules that may import argparse, matplotlib or tqdm: the command-line tools and their
#: ``python -m`` entry points.
CLI = ("core.cli", "core.sweep.__main__", "core.track", "core.calibration.__main__", "core.shape.__main__")
CLI_ONLY = ("argparse", "matplotlib", "tqdm")


MODULES = imports.modules("core")
#: {module: (core modules it imports, top-level names of the rest)}, as support.imports reads them.
GRAPH = {n: (i.inner, i.outer) for n, i in imports.graph("core").items()}


def _cycles():
    """Every import circle among core's modules."""
    return imports.cycles({n: inner for n, (inner, _) in GRAPH.items()})


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


# -- app/ (issue 47) ------------------------------------------------------------------------------

#: Most lines of a function of app/ (its decorators and docstring included): a longer one has
#: held several steps that read better as named functions each time so far.
MAX_FUNCTION_LINES = 80
#: What app/state/ may not import: the state is plain param parts and values, no page.
WEB = {"panel", "bokeh", "holoviews"}
#: The folders each folder of app/ may import (besides itself): one way, state ← kit ← serve ←
#: tabs ← report ← page ← the entry points (docs/architecture.md). ``app.tabs`` stands for every
#: tab's folder (a tab importing another tab is a rule of its own); the entry points
#: (app/main.py, app/server_lifecycle.py) may import any folder. The serving folder reads the kit
#: alone, and the Maps tab reads its warm-up's progress (what is still compiling); the study's
#: report assembles every tab's computation and views, and the page puts its buttons in the
#: sidebar, so it sits between the tabs and the page.
MAY_IMPORT = {
    "app.state": set(),
    "app.kit": {"app.state"},
    "app.serve": {"app.state", "app.kit"},
    "app.tabs": {"app.state", "app.kit", "app.serve"},
    "app.report": {"app.state", "app.kit", "app.serve", "app.tabs"},
    "app.page": {"app.state", "app.kit", "app.serve", "app.tabs", "app.report"},
}


def _role(folder):
    """The key of ``folder`` in MAY_IMPORT: ``app.tabs`` for any tab's folder."""
    return "app.tabs" if folder == "app.tabs" or folder.startswith("app.tabs.") else folder


def _tab(module):
    """``app.tabs.X`` for a module of tab X, else None."""
    parts = module.split(".")
    return ".".join(parts[:3]) if len(parts) > 3 and parts[1] == "tabs" else None


def app_breaches(root=None):
    """Every breach of app/'s layout rules under ``root``/app (default: the repository's), as
    sorted (rule, where) pairs."""
    kw = {} if root is None else {"root": root}
    graph = imports.graph("app", **kw)
    out = [("circle", " <-> ".join(c)) for c in imports.cycles({n: i.inner for n, i in graph.items()})]
    for name, imp in graph.items():
        out += [("import inside a function", f"{name}:{line} imports {t}") for line, t in imp.late]
        out += [("a tab imports another tab", f"{name} -> {t}") for t in imp.inner
                if _tab(name) and _tab(t) and _tab(t) != _tab(name)]
        mine = _role(imports.folder(name))
        if mine in MAY_IMPORT:
            out += [("imports against the one way", f"{name} -> {t}") for t in imp.inner
                    if _role(imports.folder(t)) not in MAY_IMPORT[mine] | {mine}]
        if mine == "app.state":
            out += [("the state imports the web stack", f"{name} imports {w}") for w in imp.outer & WEB]
    for name, path in imports.modules("app", **kw).items():
        out += [("a function over 80 lines", f"{name}.{q}: {n} lines")
                for q, n in imports.long_functions(path, MAX_FUNCTION_LINES)]
    return sorted(out)


def test_app_is_read():
    """The reader sees app/'s known edges (so that an empty result below means something)."""
    graph = imports.graph("app")
    assert "app.state.scenario" in graph["app.page"].inner
    assert "app.kit.offloop" in graph["app.tabs.maps.maps"].inner
    assert {"app.tabs.maps.maps", "app.tabs.design.design"} <= graph["app.page"].inner
    assert "panel" in graph["app.page"].outer
    assert any(imports.long_functions(p, 20) for p in imports.modules("app").values())


def test_app_keeps_its_layout():
    assert app_breaches() == []


def _long(name):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    return f"def {name}():\n{body}\n    return x0\n"


#: One small app/ per rule, each breaking it once: (files, the rule it breaks).
BROKEN = {
    "circle": ({"state/a.py": "from . import b\n", "state/b.py": "from . import a\n"}, "circle"),
    "late import": ({"kit/a.py": "def f():\n    from app.state import b\n", "state/b.py": ""},
                    "import inside a function"),
    "tab to tab": ({"tabs/x/v.py": "from app.tabs.y import w\n", "tabs/y/w.py": ""},
                   "a tab imports another tab"),
    "state imports panel": ({"state/a.py": "import panel as pn\n"}, "the state imports the web stack"),
    "state imports bokeh": ({"state/a.py": "from bokeh.models import Div\n"},
                            "the state imports the web stack"),
    "kit imports a tab": ({"kit/a.py": "from app.tabs.x import v\n", "tabs/x/v.py": ""},
                          "imports against the one way"),
    "tab imports the report": ({"tabs/x/v.py": "from app.report import r\n", "report/r.py": ""},
                               "imports against the one way"),
    "report imports the page": ({"report/r.py": "from app import page\n", "page.py": ""},
                                "imports against the one way"),
    "serve imports a tab": ({"serve/s.py": "from app.tabs.x import v\n", "tabs/x/v.py": ""},
                            "imports against the one way"),
    "long function": ({"page.py": _long("create_app")}, "a function over 80 lines"),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_each_app_rule_can_fail(case, tmp_path):
    """A tree breaking one rule is found out by that rule (and one that keeps it, by none)."""
    files, rule = BROKEN[case]
    _tree(tmp_path / "broken", files)
    assert rule in {r for r, _ in app_breaches(tmp_path / "broken")}, app_breaches(tmp_path / "broken")
    _tree(tmp_path / "kept", KEPT)
    assert app_breaches(tmp_path / "kept") == []


#: A small app/ that keeps every rule: each folder importing only what it may, a short function.
KEPT = {"state/a.py": "import param\n", "kit/b.py": "from app.state import a\n",
        "serve/s.py": "from app.kit import b\n",
        "tabs/x/v.py": "from app.kit import b\nfrom app.serve import s\nfrom . import w\n", "tabs/x/w.py": "",
        "report/r.py": "from app.tabs.x import v\n",
        "page.py": "import panel as pn\nfrom app.report import r\nfrom app.tabs.x import v\n\n\ndef f():\n    return v, r\n"}


def _tree(root, files):
    """Write ``files`` ({path under app/: text}) under ``root``/app, with each folder's __init__."""
    for rel, text in {"__init__.py": "", **files}.items():
        path = root / "app" / rel
        for parent in path.relative_to(root).parents[:-1]:
            (root / parent).mkdir(parents=True, exist_ok=True)
            (root / parent / "__init__.py").touch()
        path.write_text(text)


def test_the_architecture_doc_shows_apps_imports_as_they_are():
    """docs/architecture.md's table of app/'s folders is what ``python -m support.imports`` prints
    (run it and paste its table after a change that moves a module or an import)."""
    from support import ROOT

    assert imports.table("app") in (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
