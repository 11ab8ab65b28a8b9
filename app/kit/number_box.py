"""A number box: a text box kept in step with one Number or Integer parameter, that says why it
refuses what it refuses.

Bokeh's numeric inputs (Panel's ``FloatInput``, ``IntInput``, the "spinners") check a typed text
in the browser: a value outside their start/end or a text that is not a number is dropped there
without a word (``-3`` in "Reading error bound", ``500`` in "Attitudes N", ``abc`` in "Be north"
did nothing), and an emptied box sends None, which the parameter refuses with a server traceback
(the sidebar's noise box). Here the browser holds plain text, and every text reaches the server:
a number is set on the owner (an :class:`app.state.part.Part`, whose limits refuse it with a message
next to the input, the last good value restored), anything else is refused here through the
owner's :meth:`~app.state.part.Part.refuse`. The box then shows the value the owner holds.
"""

from __future__ import annotations

import threading
import weakref

import panel as pn
import param

#: Per box, its text of a value (:func:`show`), and the text shown for a slider's drag (not typed).
_TEXT_OF: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_SHOWN: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def show(box, value):
    """Show ``value`` in ``box`` (a :func:`number_box`) without setting it on its owner: the
    value of a slider being dragged, that the maps preview (app/tabs/maps/live.py); the box kept the old
    value while the maps followed the hand (issue 46 defect 8). A no-op for ``box`` None."""
    text_of = _TEXT_OF.get(box) if box is not None else None
    if text_of is not None and box.value != text_of(value):
        _SHOWN[box] = text_of(value)
        box.value = _SHOWN[box]


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


def number_box(owner, name, *, decimals=2, label=None, **widget):
    """A ``pn.widgets.TextInput`` for the Number or Integer parameter ``name`` of ``owner`` (an
    :class:`app.state.part.Part`), titled with the parameter's label (or ``label``). ``decimals``:
    the most shown (the value keeps every digit); ``widget``: further TextInput settings
    (``css_classes``, ``visible`` (may be a bound function), sizing)."""
    p = owner.param[name]
    integer = isinstance(p, param.Integer)
    # its title: ``label`` from Panel 1.9 (``name`` is deprecated there), ``name`` before it
    title = {"label" if "label" in pn.widgets.TextInput.param else "name": label or p.label}
    box = pn.widgets.TextInput(value=shown_text(getattr(owner, name), integer, decimals),
                               **{"sizing_mode": "stretch_width", **title, **widget})

    def wanted():
        """The text of the value the owner holds now."""
        return shown_text(getattr(owner, name), integer, decimals)

    def settle():
        """Show the owner's value, as it is when this runs (a later typed value may have changed
        it). Scheduled on the session's event loop after the updates already queued, so it
        comes after both deliveries of a typed text (below)."""
        text = wanted()
        if box.value != text:
            box.value = text

    # Panel delivers one Enter twice (the ``value`` change and an ``enter-pressed`` event that
    # sets ``value`` again), on two of its threads, often at once: one at a time here, or the
    # second set the refused value while the first restored the last good one, whose check
    # (Scenario.checked) skips while a restore runs, and the owner kept -1 for α.
    one_at_a_time = threading.RLock()

    def typed(event):
        if event.new == wanted() or event.new == _SHOWN.pop(box, None):
            return  # the owner's value shown (set by settle, or typed as it is shown), or a drag's
        with one_at_a_time:
            if box.value != event.new:
                return  # a later text has replaced this one; its own event takes it
            v, why = parsed(event.new, integer)
            if v is None:
                owner.refuse(name, why)  # the owner keeps its last good value
            elif v != getattr(owner, name):
                setattr(owner, name, v)  # its limits may refuse it and restore the last good value
        pn.state.execute(settle, schedule=True)

    # The owner's current value, not the event's: a refused value is restored inside the owner's
    # own watcher, so this event may already be stale.
    owner.param.watch(lambda _event: settle(), [name])
    box.param.watch(typed, ["value"])
    _TEXT_OF[box] = lambda value: shown_text(value, integer, decimals)
    return box
