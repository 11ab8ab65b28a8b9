"""Minimal Panel floor app (issue 29 item 4): ``panel serve bench/floor/panel_app.py``.

The same visible work as bokeh_app.py in Panel with a Bootstrap template: the three Bokeh figures
(bench/floor/maps.py) in ``pn.pane.Bokeh``, a ``pn.widgets.FloatSlider`` (css class ``w-Ph``, as
the dashboard's P_h input) whose ``value_throttled`` recomputes the maps and replaces their data
sources' data.
"""

import panel as pn

from bench.floor import maps

pn.extension()

figs, sources = maps.figures()
slider = pn.widgets.FloatSlider(name="P_h", start=maps.START, end=maps.END, value=maps.VALUE,
                                step=maps.STEP, css_classes=["w-Ph"])
slider.param.watch(lambda event: maps.update(sources, event.new), "value_throttled")
template = pn.template.BootstrapTemplate(title="floor: Panel")
template.sidebar.append(slider)
template.main.append(pn.Row(*[pn.pane.Bokeh(f) for f in figs]))
template.servable()
