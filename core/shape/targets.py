"""Truth models of seed 003: an extended target as a grid of dipoles, its attitude, and the
platform's pass with noise and injected outliers.

Frame (seed 003 §4.1): origin at the target's centre, x along the platform's track (its bow),
y to starboard, z down; metres, seconds, A·m², nT.

Target
------
A body of revolution about its body z axis, filled with a cubic grid of :data:`CELL` = 0.1 m
cells, one dipole of moment ``moment`` (A·m², world frame: the induced magnetisation of one
material in one external field, seed 003's (−3, 1, 5)) at the centre of each cell inside it:

- solid cylinder of height H and radius R (|z_b| ≤ H/2, x_b² + y_b² ≤ R²); seed 003 calls it a
  cylinder when H > R and a disc when H < R;
- hollow: the same minus a coaxial cavity of height H_in and radius R_in (a shell).

Cell centres sit at ±h/2, ±3h/2, … about the body origin, so the grid is symmetric.

Attitude: roll θ, pitch β, yaw φ (seed 003's [θ, β, φ]) rotate body to world as
``R = Rz(φ) · Ry(β) · Rx(θ)`` (the aerospace z-y-x convention: yaw about z, then pitch about the
new y, then roll about the newest x). Seed 003 does not print its convention; this is the one
assumed. The target's axis in the world frame is R e_z.

Pass
----
The gradiometer's centre moves on ``start + velocity · t``, t = k / rate, k = 0 … samples − 1
(seed 003: (−40, 5, −5) m, (5, 0, 0) m/s, 5 Hz; 81 samples reach x = +40 m). The closest
approach to the origin is the distance of the track's line from it.

Noise and outliers
------------------
Gaussian noise of σ per component, independent (seed 003: 0.01, unit not printed: nT/m). An
outlier adds ``size`` (in units of σ) to every listed component of one sample, with the sign
of that component's noise-free reading (so it is never absorbed), at the samples where the
platform's x is nearest each listed position (seed 003 Fig. 5: x = −20, −10, 0 m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.validation import integer, positive

__all__ = ["CELL", "CLEARANCE", "Outliers", "Pass", "Target", "attitude_matrix", "clearance"]

#: Grid cell of the truth model (m), seed 003's 0.1 m.
CELL = 0.1
#: Nearest a target cell may be to the track (m) for a pass to be run (the dashboard and the
#: command line refuse closer ones): the gradiometer's arms reach 0.25 m.
CLEARANCE = 1.0


def _vec3(name, v, unit):
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 numbers ({unit}); got {v!r}") from None
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be 3 finite numbers ({unit}); got {v!r}")
    return a


def attitude_matrix(roll, pitch, yaw):
    """Body-to-world rotation ``Rz(yaw) · Ry(pitch) · Rx(roll)``.

    Parameters
    ----------
    roll, pitch, yaw : float
        θ, β, φ of seed 003 (rad).

    Returns
    -------
    ndarray, shape (3, 3)
        Columns are the body axes in the world frame.

    Examples
    --------
    >>> import numpy as np
    >>> np.round(attitude_matrix(0, np.pi / 2, 0) @ [0, 0, 1], 12).tolist()
    [1.0, 0.0, 0.0]
    """
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _centres(extent, h):
    """Cell centres ±h/2, ±3h/2, … covering [−extent, extent]."""
    n = int(np.ceil(extent / h - 1e-9))
    return h * (np.arange(-n, n) + 0.5)


@dataclass(frozen=True)
class Target:
    """An extended ferromagnetic target: a (hollow) cylinder or disc of dipoles (module notes).

    Parameters
    ----------
    height, radius : float
        H and R (m), > 0.
    inner_height, inner_radius : float
        Cavity H_in ≤ H and R_in < R (m), 0 for a solid body.
    attitude : tuple of 3 floats
        (roll, pitch, yaw) in rad.
    moment : tuple of 3 floats
        Moment of each cell's dipole, world frame (A·m²).
    cell : float
        Grid cell (m).
    centre : tuple of 3 floats
        Body origin in the world frame (m).
    """

    height: float = 3.0
    radius: float = 0.5
    inner_height: float = 0.0
    inner_radius: float = 0.0
    attitude: tuple = (np.pi / 6, np.pi / 4, np.pi / 3)
    moment: tuple = (-3.0, 1.0, 5.0)
    cell: float = CELL
    centre: tuple = (0.0, 0.0, 0.0)
    _grid: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        H = positive("height", self.height, "m")
        R = positive("radius", self.radius, "m")
        hi = positive("inner_height", self.inner_height, "m", zero=True)
        ri = positive("inner_radius", self.inner_radius, "m", zero=True)
        if (hi > 0) != (ri > 0):
            raise ValueError("a cavity needs both inner_height and inner_radius > 0 (or both 0 for "
                             f"a solid body); got {hi!r} and {ri!r}")
        if hi > H or ri >= R:
            raise ValueError(f"the cavity must fit inside: inner_height ≤ height and inner_radius < "
                             f"radius; got H_in={hi!r} > H={H!r} or R_in={ri!r} ≥ R={R!r}")
        h = positive("cell", self.cell, "m")
        att = _vec3("attitude", self.attitude, "rad: roll, pitch, yaw")
        mom = _vec3("moment", self.moment, "A·m² per cell")
        cen = _vec3("centre", self.centre, "m")
        xy = _centres(R, h)
        zz = _centres(H / 2, h)
        X, Y, Z = np.meshgrid(xy, xy, zz, indexing="ij")
        rho2 = X**2 + Y**2
        keep = (rho2 <= R**2 + 1e-12) & (np.abs(Z) <= H / 2 + 1e-12)
        if hi > 0:
            keep &= ~((rho2 <= ri**2 + 1e-12) & (np.abs(Z) <= hi / 2 + 1e-12))
        body = np.stack([X[keep], Y[keep], Z[keep]], axis=-1)
        if body.shape[0] == 0:
            raise ValueError(f"the target holds no {h:g} m cell: make it larger or the cell smaller")
        Rm = attitude_matrix(*att)
        object.__setattr__(self, "_grid", (body @ Rm.T + cen, Rm, mom, cen))

    @property
    def positions(self):
        """Cell dipole positions in the world frame, shape (M, 3), m."""
        return self._grid[0]

    @property
    def moments(self):
        """Cell dipole moments, shape (M, 3), A·m² (all equal)."""
        return np.broadcast_to(self._grid[2], self.positions.shape)

    @property
    def total_moment(self):
        """Sum of the cells' moments (A·m²), shape (3,)."""
        return self._grid[2] * self.positions.shape[0]

    @property
    def rotation(self):
        """Body-to-world rotation (3, 3)."""
        return self._grid[1]

    @property
    def axis(self):
        """The axis of revolution in the world frame, unit (3,)."""
        return self._grid[1][:, 2]

    @property
    def kind(self):
        """Seed 003's type: "line" (a cylinder, H > R) or "plane" (a disc, H ≤ R)."""
        return "line" if self.height > self.radius else "plane"

    @property
    def main_scale(self):
        """The true main scale (m): H for a cylinder, the diameter 2R for a disc."""
        return float(self.height) if self.kind == "line" else 2.0 * float(self.radius)

    @property
    def centroid(self):
        """Mean of the cell positions (m), (3,); the body origin up to the grid's symmetry."""
        return self.positions.mean(axis=0)

    def outline(self, n=48):
        """Edges of the outer surface for plots: the two end circles and four generators.

        Returns
        -------
        list of ndarray, each (k, 3), world frame (m)
        """
        t = np.linspace(0, 2 * np.pi, n + 1)
        R, H = float(self.radius), float(self.height)
        Rm, cen = self._grid[1], self._grid[3]
        lines = [np.stack([R * np.cos(t), R * np.sin(t), np.full_like(t, s * H / 2)], -1)
                 for s in (-1, 1)]
        for a in (0, np.pi / 2, np.pi, 3 * np.pi / 2):
            lines.append(np.array([[R * np.cos(a), R * np.sin(a), -H / 2], [R * np.cos(a), R * np.sin(a), H / 2]]))
        return [ln @ Rm.T + cen for ln in lines]

    def to_dict(self):
        """The parameters, JSON-ready."""
        return {"height_m": float(self.height), "radius_m": float(self.radius),
                "inner_height_m": float(self.inner_height), "inner_radius_m": float(self.inner_radius),
                "attitude_rad": [float(a) for a in self.attitude],
                "cell_moment_Am2": [float(m) for m in self.moment], "cell_m": float(self.cell),
                "cells": int(self.positions.shape[0]),
                "total_moment_Am2": self.total_moment.tolist(), "kind": self.kind,
                "main_scale_m": self.main_scale, "axis": self.axis.tolist(),
                "centroid_m": self.centroid.tolist()}


@dataclass(frozen=True)
class Pass:
    """The platform's straight pass (module notes).

    Parameters
    ----------
    start : tuple of 3 floats
        Gradiometer centre at t = 0 (m).
    velocity : tuple of 3 floats
        Platform velocity (m/s), known (inertial navigation).
    rate : float
        Sampling rate (Hz).
    samples : int
        Number of readings.
    """

    start: tuple = (-40.0, 5.0, -5.0)
    velocity: tuple = (5.0, 0.0, 0.0)
    rate: float = 5.0
    samples: int = 81

    def __post_init__(self):
        _vec3("start", self.start, "m")
        v = _vec3("velocity", self.velocity, "m/s")
        if not np.any(v):
            raise ValueError("velocity must not be zero: the platform moves past the target")
        positive("rate", self.rate, "Hz")
        integer("samples", self.samples, 2)

    @property
    def times(self):
        """Sample times (s), (K,)."""
        return np.arange(self.samples) / float(self.rate)

    @property
    def positions(self):
        """Gradiometer centres (m), (K, 3)."""
        return np.asarray(self.start, float) + self.times[:, None] * np.asarray(self.velocity, float)

    def closest_approach(self, point=(0.0, 0.0, 0.0)):
        """Distance (m) of the track's line from ``point``."""
        s = np.asarray(self.start, float) - np.asarray(point, float)
        v = np.asarray(self.velocity, float)
        return float(np.linalg.norm(s - (s @ v) / (v @ v) * v))

    def with_closest_approach(self, cpa):
        """The same pass with its offset from the x axis scaled so the closest approach to the
        origin is ``cpa`` (m) (direction of the offset kept)."""
        cpa = positive("closest approach", cpa, "m")
        s = np.asarray(self.start, float)
        v = np.asarray(self.velocity, float)
        along = (s @ v) / (v @ v) * v
        off = s - along
        return Pass(tuple(along + off * cpa / np.linalg.norm(off)), self.velocity, self.rate, self.samples)

    def to_dict(self):
        return {"start_m": [float(a) for a in self.start], "velocity_mps": [float(a) for a in self.velocity],
                "rate_hz": float(self.rate), "samples": int(self.samples),
                "closest_approach_m": self.closest_approach()}


@dataclass(frozen=True)
class Outliers:
    """Injected outliers (module notes).

    Parameters
    ----------
    at_x : tuple of float
        Platform x positions (m); the sample nearest each gets the outlier.
    size : float
        Added magnitude in units of the noise σ.
    components : tuple of int
        Indices into the measured components (0 … m − 1) that are hit.
    """

    at_x: tuple = ()
    size: float = 500.0
    components: tuple = (0, 1, 2, 3, 4)

    def samples(self, track):
        """Indices of the hit samples on a :class:`Pass`."""
        x = track.positions[:, 0]
        return sorted({int(np.argmin(np.abs(x - a))) for a in self.at_x})

    def apply(self, z, clean, sigma, track):
        """Add the outliers to noisy readings ``z`` (..., K, m) in place; ``clean`` (K, m) gives
        each component's sign. Returns the hit sample indices."""
        hit = self.samples(track)
        comps = list(self.components)
        for k in hit:
            z[..., k, comps] += self.size * sigma * np.where(clean[k, comps] < 0, -1.0, 1.0)
        return hit

    def to_dict(self):
        return {"at_x_m": [float(a) for a in self.at_x], "size_sigma": float(self.size),
                "components": [int(c) for c in self.components]}


def clearance(target, track):
    """Distance (m) from the track's line to the target's nearest cell."""
    s = np.asarray(track.start, float)
    u = np.asarray(track.velocity, float) / np.linalg.norm(track.velocity)
    d = target.positions - s
    return float(np.min(np.linalg.norm(d - np.outer(d @ u, u), axis=1)))
