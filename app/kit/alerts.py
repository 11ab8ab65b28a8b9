"""Messages on the page: a plain-text alert box, and the scenario's refusal shown where it is about
(an input, a tab's inputs, or the page's link). Every tab shows its refusals with these."""

from __future__ import annotations

import html

import panel as pn

from . import offloop


def alert(text, kind):
    """Plain text in a Bootstrap alert box: escaped, never interpreted as HTML or Markdown."""
    fg, bg = {"danger": ("#842029", "#f8d7da"), "warning": ("#664d03", "#fff3cd"),
              "info": ("#084298", "#cfe2ff")}[kind]
    style = f"color:{fg};background:{bg};border:1px solid {fg}33;border-radius:6px;padding:8px 12px"
    return (f'<div class="alert alert-{kind}" role="alert" style="{style}">'
            f'{html.escape(text).replace(chr(10), "<br>")}</div>')


def _refused_here(message, refused, names):
    return bool(message) and (not refused if names is None else bool(set(refused) & set(names)))


def refusal(scenario, names, css):
    """The Scenario's refusal message, shown here when it is about one of ``names`` (an input, or
    a tab's inputs: each shows only its own; ``None``: a message about no input, e.g. the page's
    link)."""
    def shows(message, refused):
        return _refused_here(message, refused, names)

    return pn.pane.HTML(
        pn.bind(lambda m, r: alert(m, "danger" if "refused" in m or "Kept" in m else "warning")
                if shows(m, r) else "", scenario.param.message, scenario.param.refused),
        visible=pn.bind(shows, scenario.param.message, scenario.param.refused),
        sizing_mode="stretch_width", css_classes=[css])


def with_refusal(scenario, column, names, css):
    """``column`` (a Column holding an input) with :func:`refusal`'s message about ``names`` at its
    end while there is one: the message pane is made on the first refusal and put in the column
    only while it says something (a page of inputs carried one hidden pane each)."""
    inputs, pane = list(column.objects), []
    doc = pn.state.curdoc  # the session's (None outside a server)

    def update():
        if _refused_here(scenario.message, scenario.refused, names):
            if not pane:
                pane.append(refusal(scenario, names, css))
            if len(column.objects) == len(inputs):
                column.objects = [*inputs, pane[0]]
        elif len(column.objects) > len(inputs):
            column.objects = inputs

    # A watcher on Panel's threads: the pane's models join the page as a change of the document
    # on its loop, events held, so no later message can overtake the one bringing them
    # (offloop.soon).
    scenario.param.watch(lambda *_: offloop.soon(doc, update), ["message", "refused"])
    update()
    return column
