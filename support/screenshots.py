"""The screenshots in docs/, taken from the served dashboard in Debian's headless Chromium.

    python -m support.screenshots --out docs              # every screenshot
    python -m support.screenshots --out docs track shape  # some of them

Tests never write into the tree: this command does, when a view changed and its picture in docs/
should follow (tests/test_browser_visuals.py runs the same views into a temporary folder and
checks the images). Each view is taken at the analyst's two screens, 1600 × 1000 (``NAME.png``)
and 1280 × 800 (``NAME-1280.png``), except where ``SHOTS`` says otherwise.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from support.page import SMALL_VIEWPORT, VIEWPORT, chromium_browser
from support.server import served_app

#: Three maps drawn, each with an image of more than a handful of values.
MAPS_READY = """() => window.Bokeh && Bokeh.documents.length > 0 && Array.from(Bokeh.documents[0].all_models)
  .filter(m => m.name === 'map-image' && m.data.image[0].length > 4).length === 3"""
#: [the Track tab's PCRLB plot is drawn, a loading spinner is shown].
TRACK_STATE_JS = """() => { const ms = Array.from(Bokeh.documents[0].all_models);
  return [ms.some(m => m.title && m.title.text && m.title.text.startsWith('Track, PCRLB')),
          ms.some(m => (m.css_classes || []).includes('pn-loading'))]; }"""
#: Every text the document shows (Panel draws in shadow DOM: read from the Bokeh models).
TEXT_JS = ("() => Array.from(Bokeh.documents[0].all_models).filter(m => typeof m.text === 'string')"
           ".map(m => m.text).join(' ')")
SLOW = 120_000  # ms: a first computation on two loaded cores


def _title_js(text):
    return ("() => Array.from(Bokeh.documents[0].all_models).some(m => m.title && m.title.text "
            f"&& m.title.text.includes({text!r}))")


def _text_js(text):
    return f"() => ({TEXT_JS})().includes({text!r})"


def _maps(pg):
    pg.wait_for_function(MAPS_READY, timeout=SLOW)


def _preset(pg, name, title):
    """Click the preset button ``name`` and wait until a plot's title has ``title``."""
    pg.get_by_role("button", name=name, exact=True).first.click()
    pg.wait_for_function(_title_js(title), timeout=SLOW)


def default(pg, size):
    _maps(pg)


def fig5(pg, size):
    _maps(pg)
    _preset(pg, "Fig. 2", "P = (100, 100)")  # elsewhere first: Fig. 5 is then a change
    _preset(pg, "Fig. 5", "B: dual, d = 15 m")


def design(pg, size):
    _maps(pg)
    pg.get_by_text("Layout design", exact=True).first.click()
    pg.get_by_role("button", name="Find best spacing").wait_for(timeout=SLOW)


def track(pg, size):
    _maps(pg)
    pg.get_by_text("Track", exact=True).first.click()
    pg.wait_for_function(f"() => ({TRACK_STATE_JS})()[0] && !({TRACK_STATE_JS})()[1]", timeout=SLOW)


def sensors(pg, size):
    _maps(pg)
    pg.get_by_role("button", name="Seed 003 sensors", exact=True).first.click()
    pg.wait_for_function(_title_js("B: single, magnetometer + gradiometer"), timeout=SLOW)


def shape(pg, size):
    """The Shape tab with its four plots and the verdict (Fig. 4's pass, or offset 12 m)."""
    pg.wait_for_function(_text_js("Truth"), timeout=SLOW)
    pg.wait_for_function(_title_js("Bound"), timeout=SLOW)


def calibration(pg, size):
    pg.wait_for_function(_text_js("Rank of Γ"), timeout=SLOW)
    pg.get_by_role("button", name="Small P(0): slow filter", exact=True).first.click()
    pg.wait_for_function(_text_js("Rank of Γ"), timeout=SLOW)


#: name: (how the page is set up, the link's query, the sizes). A size's file is NAME.png at
#: 1600 × 1000 and NAME-1280.png at 1280 × 800.
SHOTS = {
    "default": (default, "", ("", "-1280")),
    "fig5": (fig5, "", ("", "-1280")),
    "design": (design, "", ("", "-1280")),
    "track": (track, "", ("", "-1280")),
    "sensors": (sensors, "", ("",)),
    "shape": (shape, "?tab=Shape", ("",)),
    "shape-1280": (shape, "?tab=Shape&shape_offset=12", ("-1280",)),  # closest approach 13 m: the span read cannot size it, the second moment can (sizable)
    "calibration": (calibration, "?tab=Calibration", ("", "-1280")),
}
SIZES = {"": VIEWPORT, "-1280": SMALL_VIEWPORT}
#: Seconds to let the last redraw settle (Bokeh paints after the models arrive).
SETTLE = 1.5


def file_name(name, size):
    base = name.removesuffix(size) if size and name.endswith(size) else name
    return f"{base}{size}"


def take(browser, url, out, names=None):
    """Write the screenshots ``names`` (default: all of :data:`SHOTS`) of the dashboard served at
    ``url`` (its base, without /app) into the folder ``out``; return the paths written. Raises
    if the page reported an error."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    unknown = sorted(set(names or ()) - set(SHOTS))
    if unknown:
        raise ValueError(f"no screenshot named {unknown}; known: {sorted(SHOTS)}")
    written = []
    for name in names or SHOTS:
        setup, query, sizes = SHOTS[name]
        for size in sizes:
            pg = browser.new_page(viewport=SIZES[size])
            errors = []
            pg.on("pageerror", lambda e: errors.append(str(e)))
            try:
                pg.goto(f"{url}/app{query}")
                pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=SLOW)
                setup(pg, size)
                time.sleep(SETTLE)
                path = out / f"screenshot-{file_name(name, size)}.png"
                pg.screenshot(path=str(path))
            finally:
                pg.close()
            if errors:
                raise RuntimeError(f"{name}{size}: the page reported {errors}")
            written.append(path)
    return written


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m support.screenshots", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True, type=Path, help="folder to write into (docs for the docs)")
    parser.add_argument("--wait", type=float, default=600, metavar="SECONDS",
                        help="how long the server may take to compile its kernels (default 600; "
                             "a first start on a cold cache on a busy machine takes longer)")
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"which screenshots (default: all): {', '.join(SHOTS)}")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.names) - set(SHOTS))
    if unknown:  # before a server is started
        parser.error(f"no screenshot named {', '.join(unknown)}; known: {', '.join(SHOTS)}")
    with served_app(timeout=args.wait) as (url, _), chromium_browser() as browser:
        for path in take(browser, url, args.out, args.names or None):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
