"""Drag floor in Panel (issue 38): ``panel serve bench/floor/drag_panel_app.py``.

The three maps of bench/floor/maps.py in a minimal Panel app: a ``FloatSlider`` whose ``value``
(every change while dragged, through Panel's own path and its debounce) redraws them, as
bench/bench_drag.py measures beside the dashboard. The image sources are named ``map-image``.
"""

import panel as pn

from bench.floor import maps

pn.extension()

figs, sources = maps.figures()
for src in sources:
    src.name = "map-image"
slider = pn.widgets.FloatSlider(name="P_h", start=maps.START, end=maps.END, value=maps.VALUE,
                                step=maps.STEP, css_classes=["w-Ph"])
slider.param.watch(lambda event: maps.update(sources, event.new), "value")
template = pn.template.BootstrapTemplate(title="drag floor: Panel")
template.sidebar.append(slider)
template.main.append(pn.Row(*[pn.pane.Bokeh(f) for f in figs]))
template.servable()
