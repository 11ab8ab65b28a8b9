"""Station layouts and planes of target positions to evaluate maps on."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels import gamma as kernels
from ..model import validation

__all__ = ["Plane", "dual_station", "single_station", "velocity_from_heading"]

#: Largest number of grid points along one axis that a map accepts.
MAX_RESOLUTION = 1000


def single_station(h):
    """The paper's single station at (0, 0, h) (m). Returns shape (1, 3)."""
    return np.array([[0.0, 0.0, float(h)]])


def dual_station(h, d):
    """The paper's dual layout: station 1 at (0, 0, h), station 2 at (d, 0, h) (m). Shape (2, 3)."""
    return np.array([[0.0, 0.0, float(h)], [float(d), 0.0, float(h)]])


def velocity_from_heading(speed, heading_deg):
    """(vx, vy) in m/s from a speed (m/s) and a heading in degrees from +x towards +y."""
    rad = np.deg2rad(heading_deg)
    return float(speed * np.cos(rad)), float(speed * np.sin(rad))


@dataclass(frozen=True)
class Plane:
    """A rectangular grid of target positions.

    ``kind="xy"``: horizontal plane at depth ``fixed`` = z (m); axes x (columns) and y (rows).
    ``kind="xz"``: vertical plane at ``fixed`` = y (m); axes x (columns) and z (rows).
    ``u`` and ``v`` are the (min, max) of the column and row axes (m); ``n`` points along each.
    """

    kind: str
    u: tuple
    v: tuple
    fixed: float
    n: int

    def __post_init__(self):
        if self.kind not in ("xy", "xz"):
            raise ValueError(f"plane kind must be 'xy' or 'xz'; got {self.kind!r}")
        validation.integer("grid resolution n", self.n, 2, MAX_RESOLUTION)
        for name, rng in (("u", self.u), ("v", self.v)):
            lo, hi = (float(a) for a in rng)
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(f"plane range {name} must be finite (min, max) with min < max; got {rng!r}")
        if not np.isfinite(self.fixed):
            raise ValueError(f"plane's fixed coordinate must be finite; got {self.fixed!r}")

    @property
    def axes(self):
        """(u values (n,), v values (n,)) in m."""
        return np.linspace(*self.u, self.n), np.linspace(*self.v, self.n)

    @property
    def labels(self):
        """Axis names: ("x", "y") or ("x", "z")."""
        return ("x", self.kind[1])

    def states(self, velocity, moments, rows=slice(None)):
        """Target states on the grid (or on a slice of its rows): shape (rows, n, 5 + moments),
        (rows, n, 7) for the electric (Ph, Pv), 8 for a magnetic moment vector."""
        u, v = self.axes
        v = v[rows]
        template = np.array([0.0, self.fixed, self.fixed, *velocity, *moments], dtype=np.float64)
        out = np.empty((v.size, u.size, template.size))
        kernels.grid_states(template, u, v, 1 if self.kind == "xy" else 2, out)
        return out
