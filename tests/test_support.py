"""The support package (support/): helpers of tests and benchmarks, one-way imports, markers."""

import ast
import subprocess
import sys

import pytest

from support import ROOT
from tests.conftest import markers_of_file


def imports_of(path):
    """Every module a file imports (absolute names; ``from x import y`` gives x and x.y)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out |= {f"{node.module}.{a.name}" for a in node.names}
    return out


def python_files(*folders):
    return [p for f in folders for p in sorted((ROOT / f).rglob("*.py"))]


def test_the_shipped_packages_import_neither_support_nor_tests():
    found = [(str(p.relative_to(ROOT)), m) for p in python_files("core", "app", "paper")
             for m in imports_of(p) if m.split(".")[0] in ("support", "tests", "bench")]
    assert found == []


def test_bench_and_support_import_no_test_module():
    found = [(str(p.relative_to(ROOT)), m) for p in python_files("bench", "support")
             for m in imports_of(p) if m.split(".")[0] == "tests"]
    assert found == []


def test_importing_support_loads_no_browser_and_no_app():
    """Importing the helpers costs nothing a test does not use: Playwright is imported when a
    browser is launched, the dashboard is served in a process of its own."""
    code = ("import sys, support, support.server, support.page, support.symbolic\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'playwright', 'app', 'tests', 'bench'}))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         timeout=120, check=True)
    assert out.stdout.strip() == "[]"


def test_the_loopback_port_given_is_free():
    code = ("import socket\nfrom support.server import free_port\nport = free_port()\n"
            "s = socket.socket(); s.bind(('127.0.0.1', port)); s.close(); print(port)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         timeout=60, check=True)
    assert 0 < int(out.stdout) < 65536


@pytest.mark.parametrize("source, expected", [
    ("from support.page import chromium_browser\n", {"browser"}),
    ("from support.server import served_app\n", {"server"}),
    ("from support.page import CHROMIUM\nfrom support.server import served_app\n", {"browser", "server"}),
    ("def f():\n    from support import server\n", {"server"}),  # a late import counts too
    ("import support.page\n", {"browser"}),
    ("from support import ROOT, symbolic\n", set()),
    ("from support import screenshots\n", {"browser", "server"}),
    ("import numpy\n", set()),
])
def test_a_file_is_marked_by_what_it_imports(tmp_path, source, expected):
    path = tmp_path / "test_x.py"
    path.write_text(source)
    assert markers_of_file(str(path)) == expected


def test_every_file_that_launches_chromium_or_serves_the_app_is_marked():
    """The other way round: a test file that reaches Playwright or ``panel serve`` without the
    support package would escape the markers (and the fast lane would start a browser)."""
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        if path.name == "test_support.py":  # names them in this test's own text
            continue
        text = path.read_text(encoding="utf-8")
        marks = markers_of_file(str(path))
        if "sync_playwright" in text or "chromium.launch" in text:
            assert "browser" in marks, path.name
        if '"panel", "serve"' in text:
            assert marks & {"server"} or "pytest.mark.container" in text, path.name


def test_the_markers_are_registered_and_strict():
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert "--strict-markers" in text
    for name in ("browser", "server", "container"):
        assert f'"{name}: ' in text
