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
message (:meth:`app.scenario.Part.refuse`), shown next to the input, the
last good value kept.
"""

from __future__ import annotations

import panel as pn
import param


def shown_text(value, integer=False, decimals=2):
    """The box's text for ``value``: at most ``decimals`` decimals, trailing zeros dropped
    (``100``, ``2.83``), or 6 significant digits for a value too small or large for them
    (``1e-07``). Only shown: the value is the owner's, never re-read from this text."""
    if integer:
        return str(int(value))
    v = float(value)
    if v != 0 and (abs(v) < 10.0 ** -decimals or abs(v) >= 1e7):
        return f"{v:.6g}"
    return f"{v:.{decimals}f}".rstrip("0").rstrip(".") if v != 0 else "0"


def parsed(text, integer=False):
    """(value, '') of a typed text, or (None, why it is not a number)."""
    cleaned = str(text).strip().replace("\u2212", "-").replace(" ", "")
    if not cleaned:
        return None, "empty: type a number"
    try:
        value = float(cleaned)
    except ValueError:
        hint = " (use a point for decimals)" if "," in cleaned else ""
        return None, f"“{text.strip()}” is not a number{hint}"
    if value != value or value in (float("inf"), float("-inf")):
        return None, f"“{text.strip()}” is not a finite number"
    if integer:
        if not value.is_integer():
            return None, f"“{text.strip()}” is not a whole number"
        return int(value), ""
    return value, ""


def number_input(owner, name, *, fmt="0.[00]", css_classes=(), visible=True):
    """A Column (box, slider) for the Number or Integer parameter ``name`` of ``owner``.

    The box takes any typed text; a number sets ``owner.<name>`` (the owner may refuse it and
    restore the last good one, which both then show), other text is refused with a message in
    ``owner.message`` (module docstring). The slider spans the parameter's soft bounds, widened to
    include the current value. ``fmt``: the slider's number format; ``css_classes`` and
    ``visible`` go to the Column (``visible`` may be a bound function)."""
    p = owner.param[name]
    integer = isinstance(p, param.Integer)
    lo, hi = p.get_soft_bounds()
    value = getattr(owner, name)
    lo = value if lo is None else min(lo, value)
    hi = value if hi is None else max(hi, value)
    # its title: ``label`` from Panel 1.9 (``name`` is deprecated there), ``name`` before it
    title = {"label" if "label" in pn.widgets.TextInput.param else "name": p.label}
    decimals = fmt.count("0") - 1  # "0.[00]": 2
    box = pn.widgets.TextInput(value=shown_text(value, integer, decimals), sizing_mode="stretch_width",
                               **title)
    showing = [False]  # the box's text is being set from the value: not typed
    if integer:
        slider = pn.widgets.IntSlider(start=lo, end=hi, value=value, step=p.step or 1)
    else:
        slider = pn.widgets.FloatSlider(start=lo, end=hi, value=value, step=p.step or 0.1,
                                        format=fmt)
    slider.param.update(name="", show_value=False, sizing_mode="stretch_width", margin=(0, 10, 5, 10))

    def shown(_event):
        # The owner's current value, not the event's: a refused value is restored inside the
        # owner's own watcher, so this event may already be stale.
        v = getattr(owner, name)
        slider.param.update(start=min(slider.start, v), end=max(slider.end, v), value=v)
        show(v)

    def show(v, again=False):
        showing[0] = True
        try:
            text = shown_text(v, integer, decimals)
            if again:
                # Panel drops an update equal to the last value the browser sent, as an echo of
                # it; after a refused text the last good value often is that one (typed before
                # it), and the box kept showing the refused text: step through another text
                box.value = text + " "
            box.value = text
        finally:
            showing[0] = False

    def typed_text(event):
        if showing[0]:
            return
        v, why = parsed(event.new, integer)
        if v is None:
            show(getattr(owner, name), again=True)  # the last good value
            owner.refuse(name, why)
        elif v != getattr(owner, name):
            setattr(owner, name, v)

    def typed(event):
        if event.new is not None:
            setattr(owner, name, event.new)

    owner.param.watch(shown, [name])
    box.param.watch(typed_text, ["value"])
    slider.param.watch(typed, ["value"])  # on release: the page's sliders are throttled
    return pn.Column(box, slider, css_classes=list(css_classes), visible=visible,
                     sizing_mode="stretch_width", margin=0)
