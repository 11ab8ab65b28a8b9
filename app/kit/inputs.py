"""A number the user types or drags: a box above a slider, both in step with one parameter.

Panel's ``EditableFloatSlider`` does this too, but links its two parts in the browser with a
``jscallback``, and Panel's ``Callback.registry`` (a WeakKeyDictionary whose values refer to
their keys) then keeps every closed session's whole page alive: the served app grew by ~9 MB
per session that came and went (docs/performance.md, issue 15). Here the two parts are plain
Panel widgets kept in step through Python watchers on the parameter, so nothing outlives the
session, and the page has fewer Bokeh models.

The box is a text box read here, not a numeric input: Bokeh's numeric input drops a keystroke it
cannot parse in the browser (``abc`` never appeared, and nothing said why; issue 25). Here the
text reaches the server, and what is not a number is refused through the owner's refusal
message (:meth:`app.state.part.Part.refuse`), shown next to the input, the
last good value kept.
"""

from __future__ import annotations

import panel as pn
import param

from app.state.part import declared

from .number_box import number_box, parsed, shown_text  # noqa: F401  (shown_text, parsed: as before)


def number_input(owner, name, *, fmt=None, css_classes=(), visible=True, on_slider=None):
    """A Column (box, slider) for the Number or Integer parameter ``name`` of ``owner``.

    The box takes any typed text; a number sets ``owner.<name>`` (the owner may refuse it and
    restore the last good one, which both then show), other text is refused with a message in
    ``owner.message`` (module docstring). The slider spans the parameter's soft bounds, widened to
    include the current value. ``fmt``: the slider's number format (default: the parameter's
    declared ``fmt``, app.state.part, else ``0.[00]``); ``css_classes`` and
    ``visible`` go to the Column (``visible`` may be a bound function); ``on_slider(slider, name, box)``,
    when given, is called with the slider and box made (the page's maps, and the box, follow a
    drag: app.tabs.maps.live.follow)."""
    p = owner.param[name]
    fmt = fmt or declared(p).get("fmt", "0.[00]")
    integer = isinstance(p, param.Integer)
    lo, hi = p.get_soft_bounds()
    value = getattr(owner, name)
    lo = value if lo is None else min(lo, value)
    hi = value if hi is None else max(hi, value)
    decimals = fmt.count("0") - 1  # "0.[00]": 2
    box = number_box(owner, name, decimals=decimals)
    if integer:
        slider = pn.widgets.IntSlider(start=lo, end=hi, value=value, step=p.step or 1)
    else:
        slider = pn.widgets.FloatSlider(start=lo, end=hi, value=value, step=p.step or 0.1,
                                        format=fmt)
    slider.param.update(name="", show_value=False, sizing_mode="stretch_width", margin=(0, 10, 5, 10))

    def shown(_event):
        # The owner's current value, not the event's (the box follows it too: app.kit.number_box)
        v = getattr(owner, name)
        slider.param.update(start=min(slider.start, v), end=max(slider.end, v), value=v)

    def typed(event):
        if event.new is not None:
            setattr(owner, name, event.new)

    owner.param.watch(shown, [name])
    slider.param.watch(typed, ["value"])  # on release: the page's sliders are throttled
    if on_slider is not None:  # while dragged, the maps and the box follow (app/tabs/maps/live.py)
        on_slider(slider, name, box)
    return pn.Column(box, slider, css_classes=list(css_classes), visible=visible,
                     sizing_mode="stretch_width", margin=0)
