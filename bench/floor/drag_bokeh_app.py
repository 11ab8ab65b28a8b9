"""Drag floor in plain Bokeh (issue 38): ``bokeh serve bench/floor/drag_bokeh_app.py``.

The three 200 × 200 maps of bench/floor/maps.py redrawn on every change of the slider's
``value`` while it is dragged (Bokeh's ``on_change``: no debounce, no throttle), the whole path
of a redraw as short as Bokeh makes it: what bench/bench_drag.py compares the dashboard's
previews with. The image sources are named ``map-image`` as the dashboard's are.
"""

from bokeh.io import curdoc
from bokeh.layouts import column, row
from bokeh.models import Slider

from bench.floor import maps

figs, sources = maps.figures()
for src in sources:
    src.name = "map-image"
slider = Slider(start=maps.START, end=maps.END, value=maps.VALUE, step=maps.STEP, title="P_h",
                width=360, css_classes=["w-Ph"])
slider.on_change("value", lambda attr, old, new: maps.update(sources, new))
curdoc().add_root(column(slider, row(*figs)))
curdoc().title = "drag floor: Bokeh"
