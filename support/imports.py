"""The project's imports read with ``ast``: the graph tests/test_layout.py checks and the table of
app/'s folders in docs/architecture.md (``python -m support.imports``).

Every import statement of every module under a package is read (at any depth: an import inside
a function counts as much as one at the top) and resolved to the package's modules it names; a
package's ``__init__`` counts as imported only where it is named (``from . import x`` names
``x``; ``from .pkg import name`` names ``pkg``, and ``pkg.name`` where that is a module).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path

from support import ROOT


def modules(package: str, root: Path = ROOT) -> dict:
    """{dotted name: path} of every module under ``root/package`` (a package as its
    ``__init__``)."""
    out = {}
    for path in sorted((root / package).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


@dataclass
class Imports:
    """What one module imports: ``inner`` the modules of its own package tree, ``outer`` the
    top-level names of everything else, ``late`` (line, module) of each project import made
    inside a function or class body rather than at the module's top."""

    inner: set = field(default_factory=set)
    outer: set = field(default_factory=set)
    late: list = field(default_factory=list)


def _targets(node, package, known):
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if node.level:
        base = package.split(".")
        base = base[:len(base) - (node.level - 1)]
        mod = ".".join(base + ([node.module] if node.module else []))
    else:
        mod = node.module
    # ``from pkg import x`` names the module pkg.x where there is one, else pkg
    return [f"{mod}.{a.name}" if f"{mod}.{a.name}" in known else mod for a in node.names]


def _top_level_nodes(tree):
    """The import nodes at a module's top (under ``if``/``try`` too, not in a def or class)."""
    out, todo = set(), list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            out.add(id(node))
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            todo += [n for n in ast.iter_child_nodes(node) if isinstance(n, ast.stmt)]
            todo += [n for h in getattr(node, "handlers", ()) for n in h.body]
    return out


def imports_of(name: str, path: Path, known: dict, project=("core", "app", "paper")) -> Imports:
    """What module ``name`` (at ``path``) imports; ``known``: the modules of its package tree
    (:func:`modules`); ``project``: the top-level packages whose late imports are reported."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    top, root = _top_level_nodes(tree), name.split(".")[0]
    out = Imports()
    for node in ast.walk(tree):
        if not isinstance(node, (ast.Import, ast.ImportFrom)):
            continue
        for t in _targets(node, package, known):
            head = t.split(".")[0]
            if head == root:
                if t in known:
                    out.inner.add(t)
            else:
                out.outer.add(head)
            if head in project and id(node) not in top:
                out.late.append((node.lineno, t))
    out.inner.discard(name)
    return out


def graph(package: str, root: Path = ROOT) -> dict:
    """{module: :class:`Imports`} of every module under ``package``."""
    known = modules(package, root)
    return {n: imports_of(n, p, known) for n, p in known.items()}


def cycles(edges: dict) -> list:
    """Every import circle of ``edges`` ({module: set of modules it imports}), each as a sorted
    list of its modules (Tarjan's strongly connected components)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
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

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def long_functions(path: Path, most: int) -> list:
    """(qualified name, lines) of every function of the file at ``path`` longer than ``most``
    lines (its decorators and docstring included; a nested function counts in its parent too)."""
    out = []

    def walk(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                qual = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                    if (n := child.end_lineno - first + 1) > most:
                        out.append((qual, n))
                walk(child, qual + ".")

    walk(ast.parse(path.read_text(encoding="utf-8"), str(path)), "")
    return out


def folder(module: str, depth: int = 3) -> str:
    """The folder a module of app/ belongs to, as the table shows it: ``app.tabs.maps`` for
    ``app.tabs.maps.live``, ``app.kit`` for ``app.kit.cache``, ``app.page`` for itself."""
    parts = module.split(".")
    if len(parts) > 1 and parts[1] == "tabs":
        return ".".join(parts[:depth])
    return ".".join(parts[:2])


def folder_edges(edges: dict) -> dict:
    """{folder: set of the other folders it imports} of a module graph under app/."""
    out = {}
    for mod, imp in edges.items():
        mine = folder(mod)
        out.setdefault(mine, set()).update(folder(t) for t in imp.inner if folder(t) != mine)
    return out


def table(package: str = "app") -> str:
    """A markdown table: each folder of ``package``, its modules, and the folders of the package
    it imports (docs/architecture.md holds it; tests/test_layout.py checks it is current)."""
    edges, files = graph(package), modules(package)
    by_folder = folder_edges(edges)
    rows = ["| folder | modules | imports (of app/) |", "|---|---|---|"]
    for f in sorted(by_folder, key=lambda f: (_rank(f), f)):
        mods = sorted(files[m].name for m in files if folder(m) == f and files[m].name != "__init__.py")
        uses = ", ".join(f"`{u}`" for u in sorted(by_folder[f], key=lambda f: (_rank(f), f)))
        rows.append(f"| `{f}` | {', '.join(mods) or '`__init__.py`'} | {uses or '—'} |")
    return "\n".join(rows)


#: The order of app/'s folders in the table: what the others are built on first.
ORDER = ("app", "app.state", "app.kit", "app.serve", "app.tabs", "app.report", "app.page",
         "app.server_lifecycle", "app.main")


def _rank(f):
    return next((i for i, o in reversed(list(enumerate(ORDER))) if f == o or f.startswith(o + ".")),
                len(ORDER))


if __name__ == "__main__":
    print(table("app"))
