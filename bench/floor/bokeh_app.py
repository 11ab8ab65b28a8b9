"""Minimal plain-Bokeh floor app (issue 29 item 4): ``bokeh serve bench/floor/bokeh_app.py``.

Three maps (bench/floor/maps.py) and one slider; the slider's ``value_throttled`` recomputes the
three maps and replaces their data sources' data. The slider carries the css class ``w-Ph`` as the
dashboard's P_h input does, so bench/bench_floor.py drives both with the same code.
"""

from bokeh.io import curdoc
from bokeh.layouts import column, row
from bokeh.models import Slider

from bench.floor import maps

figs, sources = maps.figures()
slider = Slider(start=maps.START, end=maps.END, value=maps.VALUE, step=maps.STEP, title="P_h",
                width=360, css_classes=["w-Ph"])
slider.on_change("value_throttled", lambda attr, old, new: maps.update(sources, new))
curdoc().add_root(column(slider, row(*figs)))
curdoc().title = "floor: Bokeh"
