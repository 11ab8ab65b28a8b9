"""The constrained free-layout search of :func:`core.optimise_layout` (spec §13): new stations
beside fixed ones, outside forbidden zones, in a depth band, a minimum spacing apart.

1. **Greedy** over a coarse candidate grid of the box (allowed points only): each new station
   in turn at the candidate that most raises the criterion, given the fixed stations and those
   already placed.
2. **Exchange** (Fedorov's, as in optimal design): each new station in turn moved to the best
   candidate with the others held, until a pass changes nothing (at most :data:`PASSES`).
3. **Powell polish** of the new stations' (x, y) within the box; a layout that breaks a
   constraint scores :data:`INFEASIBLE`, below every feasible one, so the search never leaves
   the feasible set that it starts in.

The layout returned is checked against every constraint (:meth:`LayoutConstraints.violations`)
and the better of the exchange and the polish is kept, so it is always feasible.
"""

from __future__ import annotations

from contextlib import contextmanager

import numba
import numpy as np
from scipy import optimize

from .constraints import distances

__all__: list = []

#: Candidate points per side of the box for the greedy and exchange steps.
EXCHANGE_GRID = 11
#: Most exchange passes.
PASSES = 3
#: Score of a layout that breaks a constraint (the criteria are all far above it).
INFEASIBLE = -1e12
#: Floor of a feasible layout's score (a criterion of −inf: an unobservable point with the A or
#: worst-point criterion), so that Powell's arithmetic stays finite; above INFEASIBLE.
FLOOR = -1e11


@contextmanager
def serial():
    """Run the compiled kernels on one thread here (numba's thread count is per thread): a
    criterion over a small region costs less than a parallel launch (21² points, 6 stations,
    on a loaded 2-core machine: 3 ms on one thread, 19 ms on two)."""
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def grid(box, h, cons, sea, per_side):
    (xlo, xhi), (ylo, yhi) = box
    gx, gy = np.meshgrid(np.linspace(xlo, xhi, per_side), np.linspace(ylo, yhi, per_side))
    cand = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, h)])
    return cand[cons.allowed(cand, sea)]


class Scorer:
    """The criterion of fixed + new stations, with the feasibility test and a count."""

    def __init__(self, value, cons, box, sea):
        self.value, self.cons, self.box, self.sea, self.nfev = value, cons, np.asarray(box), sea, 0

    def feasible(self, new):
        c = self.cons
        (xlo, xhi), (ylo, yhi) = self.box
        if np.any(new[:, 0] < xlo) or np.any(new[:, 0] > xhi) or np.any(new[:, 1] < ylo) \
                or np.any(new[:, 1] > yhi) or not np.all(c.allowed(new, self.sea)):
            return False
        d = distances(new, new) + np.diag(np.full(new.shape[0], np.inf))
        return bool(d.min() >= max(c.min_spacing, 0.0)) if new.shape[0] > 1 else True

    def score(self, new):
        if not self.feasible(new):
            return INFEASIBLE
        self.nfev += 1
        return max(self.value(np.vstack([self.cons.fixed, new])), FLOOR)


def _spaced(cand, others, spacing):
    """Candidates at least ``spacing`` from every station of ``others`` (and not on one)."""
    if others.shape[0] == 0:
        return cand
    return cand[distances(cand, others).min(axis=1) >= max(spacing, 1e-9)]


def _best_site(scorer, cand, new, i):
    """The best candidate for new station i (rows of ``new`` other than i held); (site, value),
    (None, −inf) when no candidate is allowed."""
    others = np.delete(new, i, axis=0)
    sites = _spaced(cand, np.vstack([scorer.cons.fixed, others]), scorer.cons.min_spacing)
    best, best_v = None, -np.inf
    for site in sites:
        trial = np.insert(others, i, site, axis=0)
        v = scorer.score(trial)
        if v > best_v:
            best, best_v = site, v
    return best, best_v


def exchange(scorer, cand, n, h):
    """Greedy then exchange passes over ``cand`` (notes 1–2); returns (new (n, 3), value)."""
    new = np.zeros((0, 3))
    for i in range(n):  # 1. greedy: station i at the best site given those placed
        site, _ = _best_site(scorer, cand, np.vstack([new, [[np.nan, np.nan, h]]]), i)
        if site is None:
            return None, -np.inf  # no room on these candidates
        new = np.vstack([new, site])
    value = scorer.score(new)
    for _ in range(PASSES):  # 2. exchange: move one station at a time to its best site
        moved = False
        for i in range(n):
            site, v = _best_site(scorer, cand, new, i)
            if site is not None and v > value + 1e-12 * abs(value):
                new[i], value, moved = site, v, True
        if not moved:
            break
    return new, value


def polish(scorer, new, maxfev):
    """Powell over the new stations' (x, y) in the box from a feasible ``new`` (note 3);
    returns (new, value) no worse than the start."""
    n, h = new.shape[0], new[0, 2]
    start = scorer.score(new)

    def objective(p):
        return -scorer.score(np.column_stack([p.reshape(n, 2), np.full(n, h)]))

    (xlo, xhi), (ylo, yhi) = scorer.box
    res = optimize.minimize(objective, new[:, :2].ravel(), method="Powell",
                            bounds=[(xlo, xhi), (ylo, yhi)] * n,
                            options={"maxfev": int(maxfev), "xtol": 1e-2, "ftol": 1e-6})
    out = np.column_stack([res.x.reshape(n, 2), np.full(n, h)])
    if -res.fun > start and scorer.feasible(out):
        return out, float(-res.fun)
    return new, start
