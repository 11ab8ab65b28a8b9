"""The maps' colour-bar tick labels (issue 40, low): one notation per bar ("100" beside "1e+4" read
as two scales), the same on the page (map_figures._TICK_JS, in Chromium) and in the PNG export
(map_data.tick_texts)."""

import pytest

from app.tabs.maps import export, data as map_data, figures as map_figures
from support.page import chromium_browser, chromium_missing

#: Tick sets of a log10-metre bar (BasicTicker's steps) and of a plain bar.
CASES = [([0.5, 1.0, 1.5, 2.0], True), ([2.0, 2.5, 3.0, 3.5, 4.0, 4.5], True),
         ([-3.0, -2.0, -1.0, 0.0], True), ([4.0, 6.0, 8.0], True), ([1.0, 1.5], True),
         ([-30.0, -25.0, -20.0], False), ([0.0, 0.25, 0.5], False)]


#: The superscript digits and minus of a power of ten, and the digits they stand for.
SUPERSCRIPTS = str.maketrans("\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b",
                             "0123456789-")


def _value(text):
    """The number a label reads: plain ("320", "\u22122.5") or a power of ten ("3×10³")."""
    if text.translate(SUPERSCRIPTS) == text:
        return float(text.replace("\u2212", "-"))
    mantissa, _, exponent = text.rpartition("10")
    return float(mantissa.rstrip("\u00d7") or 1) * 10.0 ** int(exponent.translate(SUPERSCRIPTS))


@pytest.mark.parametrize("ticks, log", CASES)
def test_a_bar_writes_all_its_ticks_in_one_notation(ticks, log):
    texts = map_data.tick_texts(ticks, log)
    powers = [t.translate(SUPERSCRIPTS) != t for t in texts]
    assert all(powers) or not any(powers), texts
    assert not any("e+" in t or "e-" in t for t in texts), texts  # no "1e+4"
    for t, text in zip(ticks, texts):  # each the tick's metres (log) or value, to 2 digits
        want = 10.0 ** t if log else t
        assert _value(text) == pytest.approx(want, rel=0.2 if any(powers) else 0.05, abs=1e-12), (text, t)


def test_a_bar_of_large_metres_is_all_powers_of_ten():
    assert map_data.tick_texts([2.0, 3.0, 4.0], True) == ["10\u00b2", "10\u00b3", "10\u2074"]
    assert map_data.tick_texts([3.5, 4.0], True) == ["3\u00d710\u00b3", "10\u2074"]
    assert map_data.tick_texts([1.0, 2.0, 3.0], True) == ["10", "100", "1000"]


def test_the_png_export_labels_its_bars_as_the_page():
    formatter = export._tick_formatter(True)
    locs = [2.0, 3.0, 4.0]
    assert formatter.format_ticks(locs) == map_data.tick_texts(locs, True)


@pytest.mark.skipif(chromium_missing(), reason="Debian's chromium is not installed (CI installs it)")
def test_the_page_writes_the_same_labels_as_the_export():
    # _TICK_JS as Bokeh's CustomJSTickFormatter runs it: a function body of its args (log) and
    # tick, index, ticks
    js = """([code, cases]) => cases.map(([ticks, log]) => {
      const f = new Function("log", "tick", "index", "ticks", code);
      return ticks.map((t, i) => f(log, t, i, ticks));
    })"""
    with chromium_browser() as browser:
        pg = browser.new_page()
        got = pg.evaluate(js, [map_figures._TICK_JS, [[t, log] for t, log in CASES]])
    assert got == [map_data.tick_texts(t, log) for t, log in CASES]
