"""Seed 003's experiments as cases: Figs. 4 and 5, and Tables 1–5 (whose rows are lost: the
rows below are our choice, each a variation of the Fig. 4 set-up in one property).

Every case runs the paper's method: seed 003's window of three lagged readings
(:data:`PAPER_LAG`, eq. (15)). Figs. 4 and 5 also carry, as a second row marked
``comparison``, the same pass with the honest one-sample update (lag 0): it does not count a
sample three times, but it reads the axis wrong by > 45° in about half of Fig. 4's passes (48 % of 40)
and loses Fig. 5's shape (docs/shape.md). The command line, the report and the dashboard's
presets all take the lag from here (``--lag`` overrides it for every row and drops the
comparison rows). A case's description names no update: :func:`describe` adds the one each
row actually runs."""

from __future__ import annotations

import numpy as np

from .experiment import Case
from .model import LAG
from .targets import Outliers, Target

__all__ = ["CASES", "FIG5_OUTLIERS", "PAPER_LAG", "TABLE_LAG", "case_rows", "describe",
           "update_label"]

PI = np.pi
#: Fig. 5's outliers: at platform x = −20, −10, 0 m, +500 σ on all five tensor components (size
#: and components are not printed; 500 σ = 5 nT/m is ~20 % of the tensor at 20 m).
FIG5_OUTLIERS = Outliers(at_x=(-20.0, -10.0, 0.0), size=500.0, components=(0, 1, 2, 3, 4))
_ATT = (PI / 6, PI / 4, PI / 3)
#: Window lag n of every case's main rows (seed 003's eq. (15), n not printed: 5).
PAPER_LAG = LAG
#: The tables' lag (the same window; kept for readers of the older name).
TABLE_LAG = PAPER_LAG


def update_label(lag):
    """What the update of window lag ``lag`` is, in words."""
    return ("one-sample update" if lag == 0 else
            f"seed 003's window update (three lagged readings, lag {lag})")


def describe(description, rows):
    """A case's description followed by the update(s) its rows actually run."""
    main = sorted({r.lag for r in rows if not r.comparison})
    cmp_ = sorted({r.lag for r in rows if r.comparison} - set(main))
    text = f"{description}; " + ", ".join(update_label(n) for n in main)
    if cmp_:
        text += "; beside it, for comparison, the " + ", ".join(update_label(n) for n in cmp_)
    return text


def _rows(label_targets, lag=PAPER_LAG, **kw):
    return [Case(name=label, target=t, lag=lag, **kw) for label, t in label_targets]


def _figure(name, **kw):
    """A figure's rows: the paper's window, and the one-sample update beside it."""
    return [Case(name=name, lag=PAPER_LAG, **kw),
            Case(name=f"{name}, one-sample update", lag=0, comparison=True, **kw)]


#: case name -> (description, list of Case rows)
CASES = {
    "seed003-fig4": ("Fig. 4: seed 003's cylinder (H 3 m, R 0.5 m, attitude (π/6, π/4, π/3), "
                     "cells (−3, 1, 5) A·m²), no outliers",
                     _figure("fig4")),
    "seed003-fig5": ("Fig. 5: as Fig. 4 with outliers of 500 σ on all five components at "
                     "platform x = −20, −10, 0 m",
                     _figure("fig5", outliers=FIG5_OUTLIERS)),
    "seed003-table1": ("Table 1 (cell moments, A·m²; rows chosen: the paper's and four "
                       "directions)",
                       _rows([(f"M = {m}", Target(moment=m)) for m in
                              ((-3, 1, 5), (5, 0, 0), (0, 5, 0), (0, 0, 5), (3, -4, 2))])),
    "seed003-table2": ("Table 2 (attitude roll, pitch, yaw; rows chosen)",
                       _rows([(f"attitude = {lab}", Target(attitude=a)) for lab, a in (
                           ("(π/6, π/4, π/3)", _ATT), ("(0, 0, 0)", (0.0, 0.0, 0.0)),
                           ("(0, π/2, 0)", (0.0, PI / 2, 0.0)), ("(π/4, π/6, −π/4)", (PI / 4, PI / 6, -PI / 4)),
                           ("(0, π/3, 2π/3)", (0.0, PI / 3, 2 * PI / 3)))])),
    "seed003-table3": ("Table 3 (cylinder sizes H, R in m; rows chosen)",
                       _rows([(f"H = {h:g}, R = {r:g}", Target(height=h, radius=r)) for h, r in
                              ((3.0, 0.5), (2.0, 0.3), (4.0, 0.5), (5.0, 0.6), (1.5, 0.4))])),
    "seed003-table4": ("Table 4 (solid and hollow cylinders H 3 m, R 0.5 m; cavities chosen)",
                       _rows([("solid", Target()),
                              ("hollow, cavity H 2.6 m R 0.3 m", Target(inner_height=2.6, inner_radius=0.3)),
                              ("hollow, cavity H 2.8 m R 0.4 m", Target(inner_height=2.8, inner_radius=0.4))])),
    "seed003-table5": ("Table 5 (solid and hollow discs; rows chosen)",
                       _rows([("solid disc H 0.3 m R 1 m", Target(height=0.3, radius=1.0)),
                              ("hollow disc H 0.3 m R 1 m, cavity H 0.1 m R 0.7 m",
                               Target(height=0.3, radius=1.0, inner_height=0.1, inner_radius=0.7)),
                              ("solid disc H 0.4 m R 1.5 m", Target(height=0.4, radius=1.5))])),
}


def case_rows(name):
    """(description, rows) of a case name (the description without its update:
    :func:`describe`); ValueError naming the accepted ones."""
    if name not in CASES:
        raise ValueError(f"case must be one of {', '.join(CASES)}; got {name!r}")
    return CASES[name]
