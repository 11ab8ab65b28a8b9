"""What a real sea changes (spec §4, §7): a section of the reproduction report.

The paper works in the homogeneous whole space, where one station with unknown moments is
structurally unobservable (Γ n = 0 along the range ↔ source-strength direction). The sea's
surface and seabed set a length scale (the depth D), which breaks that scale symmetry. This
module measures how much, with the layered-sea model of :mod:`core.model.sea`:

1. the paper's deep geometry (station at depth 100 m, target at 120 m) in a 200 m sea;
2. seed 001's sea trial (8.4 m of water, σ = 4, σb = 0.4 S/m, sensors on the seabed at
   y = ±5 m, source 0.2 m deep, 100 A·m);
3. the ratio of whole-space to layered CRLB over a shallow-water map (seed 001's geometry).
"""

from __future__ import annotations

import os

import numpy as np

import core

SIGMA = 4.0
NOISE = core.DEFAULT_NOISE
STEPS = 3

DEEP_STATE = np.array([30.0, 40.0, 120.0, 2.0, 2.0, 100.0, 20.0])
DEEP_SEAS = (core.Sea(200.0, 1.0), core.Sea(200.0, 0.1))

TRIAL_SEA = core.Sea(8.4, 0.4)
TRIAL_STATIONS = np.array([[0.0, -5.0, 8.4], [0.0, 5.0, 8.4]])
#: Seed 001 prints the start (−57.1, −280.0) m but not the speed: 2 m/s along +y is assumed.
TRIAL_VELOCITY = (0.0, 2.0)
TRIAL_MOMENTS = (100.0, 0.0)  # a horizontal pair of electrodes: Pv = 0 (still unknown)
TRIAL_POINTS = ((-57.1, -280.0), (-57.1, -100.0), (-20.0, -30.0), (10.0, 15.0))


#: Below this, a column-scaled σ_min/σ_max is round-off (a few ulps of 1): shown as such.
ROUNDOFF = 1e-15


def point_measures(state, stations, sea, steps=STEPS):
    """Rank, log10 η, column-scaled smallest singular value (σ_min/σ_max), CRLB position error
    and horizontal semi-major axis (m) of the all-rows Γ at one state."""
    opts = dict(sensor=core.Sensor("E", NOISE, SIGMA, sea), steps=steps)
    g = core.gamma(state, stations, **opts)
    gs = g / np.linalg.norm(g, axis=0)
    s = np.linalg.svd(gs, compute_uv=False)
    m = core.fisher_measures(state, stations, **opts)
    e = core.horizontal_error_ellipse(state, stations, **opts)
    return {"rank": int(core.observable_rank(state, stations, **opts)),
            "log10_eta": float(m.log10_eta), "smin": float(s[-1] / s[0]),
            "crlb": float(m.position_std), "horizontal": float(e.semi_major)}


def ratio_map(n=61, half_width=300.0):
    """Whole-space / layered CRLB over seed 001's trial geometry: targets 0.2 m deep over
    x, y ∈ [−half_width, half_width] m, the two seabed sensors. Returns the plane and, for the
    3-D position error and the horizontal semi-major axis (m, 1σ), (whole, layered) maps."""
    plane = core.Plane("xy", (-half_width, half_width), (-half_width, half_width), 0.2, n)
    common = dict(velocity=TRIAL_VELOCITY, moments=TRIAL_MOMENTS, steps=STEPS)
    maps = [core.crlb_maps(plane, TRIAL_STATIONS, sensor=core.Sensor("E", NOISE, SIGMA, sea), **common)
            for sea in (None, TRIAL_SEA)]
    return plane, {"position": tuple(m.position for m in maps),
                   "horizontal": tuple(m.semi_major for m in maps)}


def _png(path, plane, ratio):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    u, v = plane.axes
    fig, ax = plt.subplots(figsize=(5.6, 4.6), dpi=110)
    lim = np.nanmax(np.abs(np.log10(ratio)))
    im = ax.pcolormesh(u, v, np.log10(ratio), cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
    ax.plot(TRIAL_STATIONS[:, 0], TRIAL_STATIONS[:, 1], "k^", ms=6)
    ax.set(xlabel="x (m)", ylabel="y (m)", aspect="equal",
           title="log10(whole-space / layered CRLB, horizontal)\nseed 001 trial: D = 8.4 m, σb = 0.4 S/m")
    fig.colorbar(im, ax=ax, label="log10 ratio (> 0: whole space too pessimistic)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _row(label, m):
    crlb = "∞ (unobservable)" if not np.isfinite(m["crlb"]) else f"{m['crlb']:.3g}"
    hor = "∞" if not np.isfinite(m["horizontal"]) else f"{m['horizontal']:.3g}"
    # below ROUNDOFF the value is the SVD's round-off, which differs from run to run (BLAS threads,
    # compiled or cached kernels): its digits would only be noise
    smin = f"< {ROUNDOFF:g} (round-off)" if m["smin"] < ROUNDOFF else f"{m['smin']:.2e}"
    # η of a rank-deficient Γ is round-off too (its digits move by ~0.5 between kernels compiled
    # in the process and loaded from numba's cache): the verdict, not the digits
    eta = "round-off" if m["rank"] < 7 else f"{m['log10_eta']:.2f}"
    return f"| {label} | {m['rank']} | {eta} | {smin} | {crlb} | {hor} |"


def section(doc_dir=None, n=61):
    """The report section (markdown). With ``doc_dir``, also writes ``sea_crlb_ratio.png``
    there and links it."""
    head = ("| case | rank | log10 η | σ_min/σ_max (column-scaled) | CRLB position (m, 1σ) | "
            "horizontal semi-major (m, 1σ) |\n|---|---|---|---|---|---|")
    L = ["## A real sea: the surface and the seabed (spec §7)\n",
         "The figures above are in the whole space, as the paper's. With an insulating surface and "
         "a seabed (`core.Sea`, the image series of `core.model.sea`, validated against empymod) the depth "
         "D is a length scale, and the single-station scale symmetry of spec §4 is broken. How "
         f"weakly: all rows of {STEPS} instants, noise {NOISE:g} V/m per component, σ = {SIGMA:g} S/m; "
         "rank from the column-scaled SVD (`core.RANK_RTOL`), η the observability index.\n",
         f"**The paper's deep geometry** (station at depth 100 m, target at "
         f"({', '.join(f'{v:g}' for v in DEEP_STATE[:3])}) m, "
         "v = (2, 2) m/s, (Ph, Pv) = (100, 20) A·m):\n", head]
    one = core.single_station(100.0)
    L.append(_row("one station, whole space", point_measures(DEEP_STATE, one, None)))
    for sea in DEEP_SEAS:
        L.append(_row(f"one station, D = {sea.depth:g} m, σb = {sea.seabed_sigma:g} S/m",
                      point_measures(DEEP_STATE, one, sea)))
    L.append(_row("one station, D = 200 m, σb = 1 S/m, 10 instants",
                  point_measures(DEEP_STATE, one, DEEP_SEAS[0], steps=10)))
    L.append(_row("two stations d = 15 m, whole space",
                  point_measures(DEEP_STATE, core.dual_station(100.0, 15.0), None)))
    L.append("")
    L += ["**Seed 001's sea trial** (D = 8.4 m, σ = 4, σb = 0.4 S/m; 3-axis sensors on the seabed "
          f"at (0, ±5) m; source 0.2 m deep, (Ph, Pv) = {TRIAL_MOMENTS} A·m, v = {TRIAL_VELOCITY} m/s "
          "assumed — the seed gives no speed):\n", head]
    for x, y in TRIAL_POINTS:
        state = np.array([x, y, 0.2, *TRIAL_VELOCITY, *TRIAL_MOMENTS])
        for label, st in (("one sensor (0, 5)", TRIAL_STATIONS[1:]), ("two sensors", TRIAL_STATIONS)):
            for sea, name in ((None, "whole space"), (TRIAL_SEA, "layered")):
                L.append(_row(f"({x:g}, {y:g}) m, {label}, {name}", point_measures(state, st, sea)))
    plane, maps = ratio_map(n)
    L.append("")
    for key, name in (("position", "3-D position error"), ("horizontal", "horizontal semi-major axis")):
        whole, layered = maps[key]
        r = (whole / layered)[np.isfinite(whole / layered)]
        L.append(f"**Whole-space / layered CRLB, {name}**, over x, y ∈ [−300, 300] m ({n} × {n}), "
                 "seed 001's two seabed sensors, targets 0.2 m deep: ratio from "
                 f"{r.min():.2g} to {r.max():.2g} (median {np.median(r):.2g}); the whole space is too "
                 f"optimistic (ratio < 1) at {100 * np.mean(r < 1):.0f} % of the points, too "
                 f"pessimistic (ratio > 1) at {100 * np.mean(r > 1):.0f} %, and wrong by more than 2× "
                 f"either way at {100 * np.mean((r > 2) | (r < 0.5)):.0f} %. Median "
                 f"{np.nanmedian(layered):.3g} m layered against {np.nanmedian(whole):.3g} m in the "
                 "whole space.\n")
    L.append("In the thin water layer the field of a source near the surface hardly depends on its "
             "depth, so σz dominates the 3-D error; the horizontal bound is the one a tracker of a "
             "surface ship sees.\n")
    if doc_dir is not None:
        path = os.path.join(doc_dir, "sea_crlb_ratio.png")
        _png(path, plane, maps["horizontal"][0] / maps["horizontal"][1])
        L.append("![whole-space / layered CRLB ratio](sea_crlb_ratio.png)\n")
    return "\n".join(L)
