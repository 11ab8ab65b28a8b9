"""Whether the batch fit sized a pass: the Monte-Carlo that the `sizable` rule
(:mod:`core.shape.bound`) is calibrated against and checked by (docs/shape.md, *Sizable*).

A pass is *sized* when the batch fit converged to a plausible answer (:mod:`core.shape.fit`),
the read the bound names as the better (``ShapeBound.sizing``) is within
:data:`core.shape.bound.SIZABLE_FRACTION` of the true main scale, and the axis within
:data:`SIZED_AXIS_DEG`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .bound import SIZABLE_FRACTION, shape_bound
from .cases import case_rows
from .experiment import run_case
from .targets import Target

__all__ = ["KINDS", "SIZED_AXIS_DEG", "sized", "sized_share", "sweep_row"]

#: A length along the wrong axis is no size: the axis must be within this (degrees).
SIZED_AXIS_DEG = 10.0
#: The two target kinds of the calibration: seed 003's cylinder (H 3 m) and Table 5's disc
#: H 0.4 m, R 1.5 m (diameter 3 m), so that 10 % is 0.3 m for both.
KINDS = {"cylinder": Target(), "disc": Target(height=0.4, radius=1.5)}


def sweep_row(kind, cpa):
    """Fig. 4's row (seed 003's window update, its pass direction) with target ``kind`` (a
    :data:`KINDS` key) and the pass moved to closest approach ``cpa`` (m)."""
    row = case_rows("seed003-fig4")[1][0]
    row = replace(row, target=KINDS[kind])
    return replace(row, track=row.track.with_closest_approach(float(cpa)))


def sized(res, bound):
    """Per pass (R,) bool: the batch fit of :class:`~core.shape.experiment.CaseResult` ``res``
    sized the target (module notes) by the read ``bound.sizing`` names."""
    f = res.final["fit"]
    truth = res.case.target.main_scale
    line = res.case.target.kind == "line"
    read = f["spread_scale_m"] if (bound.sizing == "second moment" and line) else f["main_scale_m"]
    return (np.asarray(f["converged"], bool) & (np.abs(read - truth) <= SIZABLE_FRACTION * truth)
            & (f["axis_error_deg"] <= SIZED_AXIS_DEG))


def sized_share(row, runs=20, seed=0):
    """(share of ``runs`` passes of ``row`` the batch fit sized, the row's bound)."""
    b = shape_bound(row.target, row.track, row.noise_g)
    res = run_case(row, runs=runs, seed=seed)
    return float(np.mean(sized(res, b))), b
