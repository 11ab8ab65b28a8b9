"""The one contract of a tab: what the page needs to mount it (app/page.py's ``TABS``).

Each tab module exposes a :class:`Tab` as ``TAB``: its key (the name of its own part of the
scenario, and what :func:`app.state.applies.applies` calls the tab), its title, the inputs its
computation reads, and ``view``, which builds its layout from a :class:`Mount`. The page mounts
the tabs of its list in order; their indices, titles and visit hooks are derived from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from .shown import ALWAYS


@dataclass(frozen=True)
class Mount:
    """What a tab's view is built with: the session's ``scenario``, the process's ``cache``,
    the sidebar's widget specs (``widgets``, for pn.Param), the tab's :class:`app.kit.shown.WhenShown`
    (``shown``; always shown for the first tab), and the page's busy spinner and after-draw hook
    (``busy``, ``after_draw``: the first tab's maps use them)."""

    scenario: object
    cache: object
    widgets: dict = field(default_factory=dict)
    shown: object = ALWAYS
    busy: object = None
    after_draw: Callable | None = None


@dataclass(frozen=True)
class Tab:
    """A tab of the page. ``view(mount)`` returns its layout, or with ``sidebar`` its (inputs,
    layout): its inputs go to the sidebar, shown while it is the active tab; ``banner``: the
    page says over it which sensor kind it is for; ``waits``: hidden, its work waits until it is
    shown again (:class:`app.kit.shown.WhenShown`); ``reads``: the inputs its computation reads
    (its cache key)."""

    key: str
    title: str
    view: Callable
    reads: tuple = ()
    sidebar: bool = False
    banner: bool = False
    waits: bool = False
