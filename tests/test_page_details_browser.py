"""Small things a newcomer met on the page (issue 46, the low defects of the browser), in
headless Chromium on the served app (conftest's ``page``: its three maps drawn)."""

import re
import time

from support.drag import MAP_TEXTS_JS, handle_track
from support.page import PLOTS_WALK, value_of, wait_maps

#: Page coordinates of map ``which``'s station ``i`` (its plot view's frame scales).
STATION_XY_JS = """([which, i]) => {""" + PLOTS_WALK + """
  const pv = views[which], f = pv.frame, r = pv.el.getBoundingClientRect();
  const st = pv.model.renderers.find(g => g.data_source && g.data_source.data.name).data_source.data;
  return [r.left + f.x_scale.compute(st.x[i]), r.top + f.y_scale.compute(st.y[i])]; }"""


def _overlap(a, b):
    return not (a["x"] + a["width"] <= b["x"] or b["x"] + b["width"] <= a["x"]
                or a["y"] + a["height"] <= b["y"] or b["y"] + b["height"] <= a["y"])


def test_on_a_station_the_map_value_tooltip_is_not_covered(page):
    # issue 46 defect 12: the station's tooltip covered the map's value tooltip
    x, y = page.evaluate(STATION_XY_JS, [1, 0])  # map B (two stations): station 1
    page.mouse.move(x - 30, y - 30)
    page.mouse.move(x, y, steps=5)
    tips = page.locator(".bk-tooltip-content").filter(visible=True)
    page.wait_for_function("() => true")  # one frame
    tips.nth(1).wait_for(timeout=10_000)  # both: the station's and the map's
    texts = [tips.nth(i).text_content() for i in range(tips.count())]
    assert sorted("station 1" in t for t in texts) == [False, True], texts  # the map's, the station's
    assert all("y:" in t for t in texts), texts
    boxes = [tips.nth(i).bounding_box() for i in range(tips.count())]
    assert not _overlap(boxes[0], boxes[1]), (texts, boxes)


def _caption_ph(pg):
    """P_h of map A's caption ("P = (163.2, 20) A·m"), and whether a preview is shown."""
    title, caption, preview, *_ = pg.evaluate(MAP_TEXTS_JS)[0]
    m = re.search(r"P = \(([-\d.e+]+),", caption)
    return (float(m.group(1)) if m else None), bool(preview)


def test_the_number_box_follows_a_dragged_slider_with_the_maps(page):
    # issue 46 defect 8: the box kept the old value while the maps followed the drag
    before = float(value_of(page, "Ph"))
    cx, cy, left, width = handle_track(page, "w-Ph")
    page.mouse.move(cx, cy)
    page.mouse.down()
    for k in range(1, 9):  # the hand moves, then holds still, still down
        page.mouse.move(cx + (left + 0.8 * width - cx) * k / 8, cy)
        time.sleep(0.05)
    deadline = time.time() + 30
    while True:  # a preview of a moved value drawn, and the box showing it
        ph, preview = _caption_ph(page)
        shown = float(value_of(page, "Ph"))
        if preview and ph is not None and ph != before and abs(shown - ph) <= 0.01:
            break  # 0.01: the box shows two decimals, the caption six significant digits
        assert time.time() < deadline, f"box {shown}, maps' P_h {ph} (preview {preview}), before {before}"
        time.sleep(0.1)
    page.mouse.up()
    wait_maps(page, lambda maps: not _caption_ph(page)[1])  # the exact maps of the release
    ph, _ = _caption_ph(page)
    assert abs(float(value_of(page, "Ph")) - ph) <= 0.01 and ph != before
