"""What the paper could not say: the single station with the moments known, and the spacing d
that maximises dual-station observability over Fig. 5's region."""

from __future__ import annotations

import numpy as np

import core

from . import scenarios as sc
from .claims import NEAR_M

#: Spacings scanned (m): a log grid from 1 to 600 m plus the paper's values.
SCAN_D = tuple(float(d) for d in np.unique(np.round(np.r_[np.geomspace(1.0, 600.0, 28), 2, 10, 15, 20, 50, 100], 2)))


def d_scan(model, n, progress=None):
    """Mean measures over the Fig. 5 plane (x, y ∈ [−300, 300] m, z = 120 m) for each d.

    Returns
    -------
    dict
        ``d_optimal`` and ``d_optimal_known`` (7 and 5 unknown states): ``mean`` over the map and
        ``near_mean`` within NEAR_M of station 1 (½ log10 det F); ``crlb_median``: median CRLB
        position error (m, 7 states); ``log10_det_mean``: mean paper measure over observable points.
    """
    plane = sc.xy_plane(n)
    near = sc.horizontal_range(plane) <= NEAR_M
    out = {"d_optimal": {"mean": [], "near_mean": []}, "d_optimal_known": {"mean": [], "near_mean": []},
           "crlb_median": [], "log10_det_mean": []}
    for d in SCAN_D:
        for key, known in (("d_optimal", ()), ("d_optimal_known", sc.KNOWN)):
            v = sc.field_map(plane, d, (sc.PH, sc.PV), "d_optimal", model, known).value
            out[key]["mean"].append(float(np.nanmean(v)))
            out[key]["near_mean"].append(float(np.nanmean(v[near])))
        out["crlb_median"].append(float(np.nanmedian(
            sc.field_map(plane, d, (sc.PH, sc.PV), "crlb_position", model).value)))
        det = sc.field_map(plane, d, (sc.PH, sc.PV), "log10_det", model)
        out["log10_det_mean"].append(float(np.nanmean(np.where(det.observable, det.value, np.nan))))
        if progress is not None:
            progress()
    return out


def known_moments_summary(model, n):
    """Where the single station with known moments is strong or weak (Fig. 1 plane, 5 states).

    Returns a dict of numbers: D-opt range, CRLB position error (m) percentiles, its value right
    above the station and at the corners, and the ranges (m) where the error exceeds 10× the
    median.
    """
    plane = sc.xy_plane(n)
    dopt = sc.field_map(plane, None, (sc.PH, sc.PV), "d_optimal", model, sc.KNOWN)
    crlb = sc.field_map(plane, None, (sc.PH, sc.PV), "crlb_position", model, sc.KNOWN).value
    kw = dict(T=sc.T, sigma=sc.SIGMA, model=model, known=sc.KNOWN)
    probes = {"above station (0, 0)": (0.0, 0.0), "(100, 0)": (100.0, 0.0), "(0, 100)": (0.0, 100.0),
              "(-100, -100)": (-100.0, -100.0), "(100, 100)": (100.0, 100.0),
              "corner (300, 300)": (300.0, 300.0), "corner (300, -300)": (300.0, -300.0)}
    pts = np.array([[x, y, sc.Z, *sc.VELOCITY, sc.PH, sc.PV] for x, y in probes.values()])
    pstd = core.fisher_measures(pts, sc.stations(), **kw).position_std
    r = sc.horizontal_range(plane)
    med = np.nanmedian(crlb)
    weak = crlb > 10 * med
    # ratio to the smooth trend: error at a point vs the median error in its 50 m annulus
    edges = np.arange(0, 450, 50.0)
    ring_med = np.full_like(crlb, np.nan)
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (r >= lo) & (r < hi)
        if sel.any():
            ring_med[sel] = np.nanmedian(crlb[sel])
    anomaly = crlb / ring_med
    return {
        "observable_fraction": float(np.mean(dopt.observable)),
        "d_optimal_min": float(np.nanmin(dopt.value)), "d_optimal_max": float(np.nanmax(dopt.value)),
        "crlb_percentiles_m": {str(p): float(np.nanpercentile(crlb, p)) for p in (5, 50, 95)},
        "probes_m": {k: float(v) for k, v in zip(probes, pstd)},
        "weak_fraction": float(np.mean(weak)),
        "weak_range_m": [float(r[weak].min()), float(r[weak].max())] if weak.any() else None,
        "max_ring_anomaly": float(np.nanmax(anomaly)),
        "ring_median_m": [(float(lo), float(np.nanmedian(crlb[(r >= lo) & (r < hi)])))
                          for lo, hi in zip(edges[:-1], edges[1:]) if ((r >= lo) & (r < hi)).any()],
    }
