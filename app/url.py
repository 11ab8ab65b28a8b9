"""The scenario lives in the page URL: a pasted link reopens the view, a change is written back.

A link's values are read once, from the request; a value that would be refused is never set (no
widget shows it), the page says which and why, and it is taken out of the address bar so that a
copied link does not carry it on.
"""

from __future__ import annotations

import json
import threading
from urllib.parse import parse_qsl, urlencode

from .compute import DESIGN_FIELDS, FIELDS
from .scenario import Scenario

#: Every parameter the URL carries.
NAMES = tuple(sorted(set(FIELDS) | set(DESIGN_FIELDS)))


def link_value(raw):
    """A query value as Panel writes them: JSON where it parses, else the plain string."""
    try:
        return json.loads(raw)
    except ValueError:
        return raw


def link_problem(name, value):
    """None if a link's ``value`` for ``name`` is accepted, else why (tried on a throw-away Scenario)."""
    trial = Scenario()
    try:
        setattr(trial, name, value)
    except Exception:  # param's own type and selector checks
        return f"{name}: {trial.param[name].label} does not accept {str(value)[:40]!r}"
    if not trial.message:
        return None
    return f"{name}: {trial.message.removesuffix(' Kept the last good value.').rstrip('.')}"


def without(search, names):
    """The query string ``search`` ('?a=1&b=2' or '') without the parameters ``names``."""
    kept = [(k, v) for k, v in parse_qsl(search.lstrip("?"), keep_blank_values=True) if k not in names]
    return "?" + urlencode(kept) if kept else ""


def sync_url(scenario, location, args, onload=None):
    """Read a pasted link's values (``args``, as pn.state.session_args) into ``scenario`` once,
    and write later changes into ``location`` (a panel Location).

    Returns ``flush``: a change of the maps' values waits in the URL until the maps are drawn
    (redraw calls ``flush``). Each URL update costs the browser ~10 ms and the server an echo of
    the new address to process: ~18 ms of every slider change when it went first.

    ``onload``: pn.state.onload in a served page: refused values leave the address bar once the
    page is up (set before, the browser's own address replaced the cleaned one)."""
    good, problems = {}, {}
    for name in NAMES:
        if name in args:
            value = link_value(args[name][0].decode("utf-8", "replace"))
            problem = link_problem(name, value)
            problems.update({name: problem} if problem else {})
            good.update({} if problem else {name: value})
    scenario.param.update(good)
    if problems:  # out of the address bar: a copied link must not carry them on
        def clean():
            location.search = without(location.search or "", set(problems))

        clean() if onload is None else onload(clean)
    pending, lock = {}, threading.Lock()

    def flush():
        with lock:
            query = dict(pending)
            pending.clear()
        if query:
            location.update_query(**query)

    def to_url(*events):
        # The value the scenario holds, not the event's: a refused value's event arrives after the
        # restore of the last good one.
        now = {e.name: getattr(scenario, e.name) for e in events}
        with lock:
            pending.update({name: v if isinstance(v, str) else json.dumps(v) for name, v in now.items()})
        if not any(e.name in FIELDS for e in events):  # no maps to wait for
            flush()

    scenario.param.watch(to_url, list(NAMES))
    if problems:
        scenario.param.update(
            message=("Link values refused, defaults kept: " + "; ".join(problems.values()))[:600],
            refused=[])  # about the link, not an input the user is at: shown at the top of the page
    return flush
