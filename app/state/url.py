"""The scenario lives in the page URL: a pasted link reopens the view, a change is written back.

What the link holds is derived, not listed: every input of every part of :class:`Scenario`
(app.state.scenario.PARTS) whose value differs from its default (so every input of every tab, including the ones a rule moved, such as
the station depth a layered sea puts on the seabed), written without float noise, and the tab
shown (``tab=Track``; the first tab is the default).

A link's values are read once, from the request, and taken whole or not at all: a value that
would be refused on its own (a bound, a type), a key given twice with two values, or values that
break a rule together (a station below the link's seabed) refuse the whole link. Nothing of it is
set, and the page says which key and why. Keys that are not inputs and an unknown tab are ignored
and said. Once the page is up, the address bar shows the view the page holds (a copied link
reopens what is shown, never what was refused).
"""

from __future__ import annotations

import json
import threading
from typing import NamedTuple
from urllib.parse import parse_qsl, urlencode

import param

from .derive import LAYERED, SEABED
from .scenario import PART_OF, PARTS, Scenario, defaults, parameter

#: The query key of the tab shown.
TAB = "tab"
#: Longest link (its query, characters) the page opens: the page's own are under 3,000 (every
#: input at its longest: tests/test_link_refusal.py), a proxy's header limit is often 8 KB and
#: deploy/nginx.conf's 16 KB. A longer one is refused whole and said (issue 46 defect 5).
MAX_LINK_CHARS = 8000


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


#: What a layered sea moves when a link switches to it (app.state.scenario.Scenario._seabed), as the
#: inputs declare it (``seabed``, ``layered``): written in a layered sea's link even at their
#: defaults, so that reopening it moves none of them.
SEABED_INPUTS = (*SEABED, *LAYERED)


def query(scenario, tab=None):
    """The query string ('?a=1&b=2', or '' for the defaults) of ``scenario`` on tab ``tab``
    (its title; None or the first tab's: not written)."""
    default = defaults()
    values = scenario.values()
    always = SEABED_INPUTS if values["sea_model"] == "layered" else ()
    pairs = [(n, link_text(v)) for n, v in values.items() if v != default[n] or n in always]
    if tab:
        pairs.append((TAB, tab))
    return "?" + urlencode(pairs) if pairs else ""


def link_problem(name, value):
    """None if a link's ``value`` for ``name`` is accepted on its own, else why: param's own type,
    selector and bound checks (tried on a throw-away part) and the part's limits (:meth:`app.state.part.Part.problem`).
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


class Link(NamedTuple):
    """What :func:`read_link` found in a link."""
    problems: dict  # key -> why, for a refused link (nothing of it set); {} if it was taken
    tab: str | None  # the tab's title (matched without case), None for none or an unknown one
    ignored: list  # what was ignored, said: keys that are no input, an unknown tab


def read_link(scenario, args, titles=()):
    """Set a pasted link's values (``args``, as pn.state.session_args) on ``scenario`` at once,
    all of them or, if one is refused, none (module notes). ``titles``: the page's tabs, to
    match ``tab=`` against."""
    good, problems, ignored = {}, {}, []
    size = len(urlencode([(k, r) for k, raws in args.items() for r in raws]))
    if size > MAX_LINK_CHARS:
        return Link({"link": f"it is {size:,} characters long, and the page opens links of at most "
                             f"{MAX_LINK_CHARS:,} (its own are far shorter): copy the link again "
                             "from the address bar of the view you want"}, None, [])
    for key, raws in args.items():
        texts = [r.decode("utf-8", "replace") if isinstance(r, bytes) else r for r in raws]
        if key == TAB:
            continue
        if key not in PART_OF:
            ignored.append(f"{key[:40]!r} (not an input of this page)")
            continue
        if len(set(texts)) > 1:
            problems[key] = f"{key}: given {len(texts)} times ({', '.join(t[:20] for t in texts[:4])})"
            continue
        value = link_value(texts[0], key)
        problem = link_problem(key, value)
        problems.update({key: problem} if problem else {})
        good.update({} if problem else {key: value})
    if good and not problems:
        scenario.update(good, as_given=True)
        if scenario.message.endswith("Kept the last good value."):  # a rule between its values
            why = scenario.message.removesuffix(" Kept the last good value.").rstrip(".")
            keys = [n for n in good if parameter(n).label.split(" (")[0] in why] or list(good)
            problems = {n: f"{n}: {why}" for n in keys[:1]} or {"link": why}
    tab = None
    if TAB in args:
        asked = args[TAB][0]
        asked = asked.decode("utf-8", "replace") if isinstance(asked, bytes) else asked
        tab = next((t for t in titles if t.lower() == asked.strip().lower()), None)
        if titles and tab is None:
            ignored.append(f"tab {asked[:40]!r} (the tabs are {', '.join(titles)})")
        elif not titles:
            tab = asked
    return Link(problems, tab, ignored)


def link_message(link):
    """What the page says at its top about link ``link`` ('' when there is nothing to say)."""
    said = []
    if link.problems:
        said.append("Link refused, nothing of it applied (the defaults are shown): "
                    + "; ".join(link.problems.values()) + ".")
    if link.ignored:
        said.append("Ignored in the link: " + "; ".join(link.ignored) + ".")
    return " ".join(said)[:800]


def sync_url(scenario, location, args, onload=None, tabs=None, titles=(), waits=None, link=None):
    """Read a pasted link (``args``, as pn.state.session_args) into ``scenario`` (and ``tabs``, a
    pn.Tabs whose tabs are named ``titles``, its active tab) once, and keep ``location`` (a panel
    Location) in step with them.

    Returns ``flush``: a change that redraws the maps (``waits(names)`` true for the names of the
    changed parameters) waits in the URL until the maps are drawn (redraw calls ``flush``). Each
    URL update costs the browser ~10 ms and the server an echo of the new address to process:
    ~18 ms of every slider change when it went first. Other changes are written at once.

    ``onload``: pn.state.onload in a served page: the address bar is set to the view once the
    page is up (set before, the browser's own address replaced it).
    ``link``: the link as :func:`read_link` already read it into ``scenario`` (read once: a
    second read of the same values saw the first one's layered sea and refused them)."""
    titles = list(titles)
    link = read_link(scenario, args, titles) if link is None else link
    if tabs is not None and link.tab in titles:
        tabs.active = titles.index(link.tab)
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

    def show_view():  # the address bar holds the view shown: refused and ignored keys leave it
        new = query(scenario, shown_tab())
        if new != (location.search or ""):
            location.search = new

    show_view() if onload is None else onload(show_view)
    scenario.watch(to_url, PARTS)
    if tabs is not None:
        tabs.param.watch(to_url, ["active"])
    said = link_message(link)
    if said:  # about the link, not an input the user is at: shown at the top of the page
        scenario.param.update(message=said, refused=[])
    return flush
