"""Debian's headless Chromium through Playwright, and what a served dashboard draws.

One way to launch the browser (never a downloaded one: ``executable_path`` is Debian's chromium,
with the flags every test and benchmark uses) and the few reads of the live Bokeh documents that
tests and benchmarks share. Playwright is imported when a browser is launched, so importing this
module needs no browser.
"""

from __future__ import annotations

import contextlib
import html
import os
import re
import time

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: The analyst's screens: the first is every test's default.
VIEWPORT = {"width": 1600, "height": 1000}
SMALL_VIEWPORT = {"width": 1280, "height": 800}


def chromium_missing():
    """True when Debian's chromium is absent and this is not CI (CI installs it: there, a browser
    test must run, not skip)."""
    return not os.path.exists(CHROMIUM) and not os.environ.get("CI")


@contextlib.contextmanager
def chromium_browser():
    """Debian's headless Chromium driven by Playwright (never a downloaded browser)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()


def open_page(browser, url, errors, viewport=VIEWPORT, console=True, requests=False):
    """A new page of ``browser`` at ``url``, once Bokeh has a document. Its uncaught errors are
    appended to ``errors``, and so are its console errors (``console``) and the URLs of its
    failed requests (``requests``): the caller asserts there are none."""
    pg = browser.new_page(viewport=viewport)
    if console:
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: errors.append(str(e)))
    if requests:
        pg.on("requestfailed", lambda r: errors.append(f"request failed: {r.url}"))
    pg.goto(url)
    pg.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
    return pg


#: The start of a script that reads the maps: collects ``views``, the view of every plot on the
#: page in page order, walked from the live Bokeh views (Panel draws in shadow DOM), and
#: ``plots``, their models. A script is ``"() => {" + PLOTS_WALK + "return …; }"``.
PLOTS_WALK = """
  const views = [];
  const walk = (v) => { if (!v) return;
    if (v.model && v.model.renderers !== undefined && v.model.title !== undefined) views.push(v);
    for (const c of (v.child_views ? Array.from(v.child_views) : [])) walk(c); };
  for (const v of Object.values(Bokeh.index)) walk(v);
  const plots = views.map(v => v.model);
"""
#: For every plot on screen: [title, [sum of each image layer's finite values]] (map, veil):
#: a fingerprint of what is drawn, read from the live Bokeh views.
MAPS_JS = """() => {""" + PLOTS_WALK + """
  return plots.map(p => [p.title ? p.title.text : "",
    p.renderers.filter(r => r.data_source && r.data_source.data.image && r.data_source.data.image.length).map(r => {
      let s = 0; const a = r.data_source.data.image[0];
      for (let i = 0; i < a.length; i++) if (!isNaN(a[i])) s += a[i];
      return s; })]);
}"""

#: Titles and renderer counts of the plots, every axis label, and the text of the panes that
#: mention runs (the Track tab's summary line): read from the live Bokeh document (Panel draws in
#: shadow DOM).
PLOTS_JS = """() => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.renderers !== undefined && m.title !== undefined && m.title && m.title.text)
      out.push([m.title.text, m.renderers.length]);
  const labels = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.axis_label !== undefined && m.axis_label) labels.push(m.axis_label);
  const texts = [];
  for (const m of Bokeh.documents[0].all_models)
    if (typeof m.text === "string" && m.text.includes("runs")) texts.push(m.text);
  return [out, labels, texts.join(" ")];
}"""


def maps(pg):
    """What :data:`MAPS_JS` reads from the page ``pg``."""
    return pg.evaluate(MAPS_JS)


def wait_maps(pg, predicate, timeout=30.0):
    """Poll what is drawn until ``predicate(maps)`` holds; return it."""
    deadline = time.time() + timeout
    while True:
        drawn = maps(pg)
        if predicate(drawn):
            return drawn
        if time.time() > deadline:
            raise AssertionError(f"the maps did not reach the expected state: {drawn}")
        time.sleep(0.2)


def wait_plots(pg, predicate, timeout=90.0):
    """Poll :data:`PLOTS_JS` until ``predicate(got, text)`` holds (``text``: the summary's text
    without its HTML); return both."""
    deadline = time.time() + timeout
    while True:
        got = pg.evaluate(PLOTS_JS)
        text = re.sub(r"<[^>]+>", "", html.unescape(html.unescape(got[2])))  # markdown's HTML
        if predicate(got, text):
            return got, text
        if time.time() > deadline:
            raise AssertionError(f"the tab did not reach the expected state: {got} / {text[:300]}")
        time.sleep(0.3)


def value_of(pg, name):
    """The text in the input box of the widget with CSS class ``w-{name}``."""
    return pg.locator(f".w-{name} input").first.input_value()


def wait_value(pg, name, expected, timeout=15.0):
    """Poll until the box of ``name`` reads the number ``expected``."""
    deadline = time.time() + timeout
    while float(value_of(pg, name)) != expected:
        if time.time() > deadline:
            raise AssertionError(f"{name} shows {value_of(pg, name)}, expected {expected}")
        time.sleep(0.1)


def select(pg, name, option):
    """Choose ``option`` in the select of ``name``."""
    pg.locator(f".w-{name} select").first.select_option(option)


def type_value(pg, name, value):
    """Type ``value`` into the box of ``name`` and press Enter, as a user does."""
    box = pg.locator(f".w-{name} input").first
    box.fill(str(value))
    box.press("Enter")


def wait_count(locator, n, timeout=30.0):
    """Poll until ``locator`` matches ``n`` elements."""
    deadline = time.time() + timeout
    while locator.count() != n:
        if time.time() > deadline:
            raise AssertionError(f"expected {n} of {locator}, found {locator.count()}")
        time.sleep(0.2)
