"""The paper's presets (spec §5) and cached map evaluations built on :mod:`core`.

Every number the figures and the claims use comes from :func:`field_map`, a thin cached wrapper
around :func:`core.evaluate_map`, so that a figure panel and the claim checked on it read the
same array.
"""

from __future__ import annotations

import functools

import numpy as np

import core

#: Common parameters of the paper (spec §5): moments (A·m), station depth h and target depth z
#: (m, same axis), velocity (m/s), sample interval T (s).
PH, PV = 100.0, 20.0
H, Z = 100.0, 120.0
VELOCITY = (2.0, 2.0)
T = 1.0
SIGMA = 4.0
MODELS = ("exact", "paper")
#: Ranges of the planes (m). Fig. 1's range is not printed; the spec fixes ±300 m.
XY_RANGE = (-300.0, 300.0)
XZ_X, XZ_Z, XZ_Y = (-300.0, 300.0), (100.0, 400.0), 50.0
#: Fig. 4's moment pairs (Ph, Pv), A·m, all with Ph² + Pv² ≈ 100².
FIG4_MOMENTS = ((100.0, 0.0), (70.7, 70.7), (0.0, 100.0))
#: Fig. 4's differences, (more vertical) − (more horizontal): indices into FIG4_MOMENTS.
FIG4_PAIRS = ((1, 0), (2, 1), (2, 0))
FIG5_D = (2.0, 15.0)
FIG6_D, FIG6_BASE = (20.0, 50.0, 100.0), 10.0
#: The dual spacing (m) used for the dual-station analysis when a claim is about one station.
DUAL_D = 15.0
#: The physically consistent single-station analysis: moments known, 5 unknown states.
KNOWN = ("Ph", "Pv")


def xy_plane(n, z=Z):
    """Figs. 1, 3–6: x, y ∈ [−300, 300] m at target depth z (m)."""
    return core.Plane("xy", XY_RANGE, XY_RANGE, float(z), int(n))


def xz_plane(n):
    """Fig. 2: x ∈ [−300, 300] m, z ∈ [100, 400] m at y = 50 m."""
    return core.Plane("xz", XZ_X, XZ_Z, XZ_Y, int(n))


def stations(d=None):
    """Single station at (0, 0, h) when ``d`` is None, else the dual layout with spacing d (m)."""
    return core.single_station(H) if d is None else core.dual_station(H, d)


@functools.lru_cache(maxsize=512)
def field_map(plane, d=None, moments=(PH, PV), measure="log10_det", model="exact", known=()):
    """:func:`core.evaluate_map` for one preset; cached (results are read-only arrays).

    Parameters
    ----------
    plane : core.Plane
    d : float or None
        Station spacing (m) of the dual layout; None for the single station.
    moments : (Ph, Pv) in A·m
    measure : str
        One of :data:`core.MEASURES`.
    model : {"exact", "paper"}
    known : tuple of str
        States treated as known.

    Returns
    -------
    core.MapResult
        ``value`` and ``observable`` of shape (n, n), rows along the plane's second axis.
    """
    res = core.evaluate_map(plane, stations(d), velocity=VELOCITY, moments=tuple(moments),
                            measure=measure, T=T, sensor=core.Sensor("E", sigma=SIGMA, model=model),
                            known=tuple(known))
    res.value.setflags(write=False)
    res.observable.setflags(write=False)
    return res


def horizontal_range(plane, centre=(0.0, 0.0)):
    """Horizontal distance (m) of every grid point from ``centre`` (x, y); shape (n, n)."""
    u, v = plane.axes
    if plane.kind == "xy":
        return np.hypot(u[None, :] - centre[0], v[:, None] - centre[1])
    return np.hypot(u[None, :] - centre[0], plane.fixed - centre[1]) * np.ones((v.size, 1))
