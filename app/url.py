"""The scenario lives in the page URL: a pasted link reopens the view, a change is written back.

What the link holds is derived, not listed: every input of every part of :class:`Scenario`
(app.scenario.PARTS) whose value differs from its default (so every input of every tab, including the ones a rule moved, such as
the station depth a layered sea puts on the seabed), written without float noise, and the tab
shown (``tab=Track``; the first tab is the default).

A link's values are read once, from the request; a value that would be refused is never set (no
widget shows it), the page says which and why, and it is taken out of the address bar so that a
copied link does not carry it on.
"""

from __future__ import annotations

import json
import threading
from urllib.parse import parse_qsl, urlencode

import param

from .scenario import PART_OF, PARTS, Scenario, defaults, parameter

#: The query key of the tab shown.
TAB = "tab"


def names():
    """Every input a link carries: every part's (the feedback is not a part's)."""
    return tuple(PART_OF)


def link_value(raw, name=None):
    """A query value as written by :func:`query`: JSON where it parses (numbers, lists), else the
    plain string; a String parameter ``name`` always takes the plain string."""
    if name is not None and isinstance(parameter(name), param.String):
        return raw
    try:
        return json.loads(raw)
    except ValueError:
        return raw


def link_text(value):
    """A value as the link writes it: floats with 12 significant digits (``65.9``, not the
    slider's ``65.89999999999999``), lists as JSON of such numbers, strings as they are."""
    if isinstance(value, str):
        return value
    if isinstance(value, float):
        return format(value, ".12g")
    if isinstance(value, list):
        return json.dumps(_rounded(value), separators=(",", ":"))
    return json.dumps(value)


def _rounded(value):
    if isinstance(value, list):
        return [_rounded(v) for v in value]
    return float(format(value, ".12g")) if isinstance(value, float) else value


def query(scenario, tab=None):
    """The query string ('?a=1&b=2', or '' for the defaults) of ``scenario`` on tab ``tab``
    (its title; None or the first tab's: not written)."""
    default = defaults()
    pairs = [(n, link_text(v)) for n, v in scenario.values().items() if v != default[n]]
    if tab:
        pairs.append((TAB, tab))
    return "?" + urlencode(pairs) if pairs else ""


def link_problem(name, value):
    """None if a link's ``value`` for ``name`` is accepted on its own, else why: param's own type,
    selector and bound checks (tried on a throw-away part) and the part's limits (:meth:`app.scenario.Part.problem`).
    Rules between values (z_min < z_max, depths in the water column) are checked on the link's
    values together, by :func:`read_link`."""
    trial = PARTS[PART_OF[name]]()  # a part on its own: no owner, no checks but param's
    try:
        setattr(trial, name, value)
    except Exception:  # param's own type and selector checks
        return f"{name}: {parameter(name).label} does not accept {str(value)[:40]!r}"
    problem = Scenario.problem(name, value)
    return f"{name}: {problem}" if problem else None


def without(search, names):
    """The query string ``search`` ('?a=1&b=2' or '') without the parameters ``names``."""
    kept = [(k, v) for k, v in parse_qsl(search.lstrip("?"), keep_blank_values=True) if k not in names]
    return "?" + urlencode(kept) if kept else ""


def read_link(scenario, args):
    """Set a pasted link's accepted values (``args``, as pn.state.session_args) on ``scenario``
    at once; return ({name: why} of the refused ones, the tab title or None)."""
    good, problems = {}, {}
    for name in names():
        if name in args:
            value = link_value(args[name][0].decode("utf-8", "replace"), name)
            problem = link_problem(name, value)
            problems.update({name: problem} if problem else {})
            good.update({} if problem else {name: value})
    scenario.update(good)
    if scenario.message and scenario.refused != ["sea_model"]:  # a rule between the link's values
        why = scenario.message.removesuffix(" Kept the last good value.").rstrip(".")
        problems.update({name: f"{name}: {why}" for name in scenario.refused})
    tab = args[TAB][0].decode("utf-8", "replace") if TAB in args else None
    return problems, tab


def sync_url(scenario, location, args, onload=None, tabs=None, titles=(), waits=None):
    """Read a pasted link (``args``, as pn.state.session_args) into ``scenario`` (and ``tabs``, a
    pn.Tabs whose tabs are named ``titles``, its active tab) once, and keep ``location`` (a panel
    Location) in step with them.

    Returns ``flush``: a change that redraws the maps (``waits(names)`` true for the names of the
    changed parameters) waits in the URL until the maps are drawn (redraw calls ``flush``). Each
    URL update costs the browser ~10 ms and the server an echo of the new address to process:
    ~18 ms of every slider change when it went first. Other changes are written at once.

    ``onload``: pn.state.onload in a served page: refused values leave the address bar once the
    page is up (set before, the browser's own address replaced the cleaned one)."""
    problems, tab = read_link(scenario, args)
    titles = list(titles)
    if tabs is not None and tab in titles:
        tabs.active = titles.index(tab)
    if problems:  # out of the address bar: a copied link must not carry them on
        def clean():
            location.search = without(location.search or "", set(problems))

        clean() if onload is None else onload(clean)
    pending, lock = [False], threading.Lock()

    def shown_tab():
        if tabs is None or not titles or tabs.active == 0:
            return None
        return titles[tabs.active]

    def flush():
        with lock:
            due = pending[0]
            pending[0] = False
        if due:
            new = query(scenario, shown_tab())
            if new != (location.search or ""):
                location.search = new

    def to_url(*events):
        with lock:
            pending[0] = True
        if waits is None or not waits([e.name for e in events]):  # no maps to wait for
            flush()

    scenario.watch(to_url, PARTS)
    if tabs is not None:
        tabs.param.watch(to_url, ["active"])
    if problems:
        scenario.param.update(
            message=("Link values refused, defaults kept: " + "; ".join(problems.values()))[:600],
            refused=[])  # about the link, not an input the user is at: shown at the top of the page
    return flush
