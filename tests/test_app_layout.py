"""app/ by role (issue 39): no module so long that it mixes roles."""

from support import ROOT

#: Most lines a module of app/ may have: past it, a module has held two roles each time so far
#: (the maps' pixels and their Bokeh models; the maps' computation and the process's cache).
MAX_LINES = 500


def test_no_module_in_app_is_over_500_lines():
    long = {str(p.relative_to(ROOT)): n for p in sorted((ROOT / "app").rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}


def test_the_count_sees_app():
    """The files counted are app/'s (so that an empty result above means something)."""
    assert (ROOT / "app" / "tabs" / "maps" / "compute.py").is_file() and (ROOT / "app" / "main.py").is_file()
