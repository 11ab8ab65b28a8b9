"""Pure view functions of the tabs' CRLB maps (HoloViews elements): the Layout design and Track tabs.

The comparison maps are plain Bokeh figures updated in place: :mod:`app.tabs.maps.figures`."""

from __future__ import annotations

from dataclasses import dataclass

import holoviews as hv
import numpy as np

import core

from app.state.scenario import ERROR_QUANTITIES

from .runaway import RUNAWAY_LIMIT, runaway, runaway_dots

hv.extension("bokeh", logo=False)

VEIL = "#7f7f7f"


def axes(plane):
    """(x dimension, second dimension) with units, for a core.Plane."""
    second = "y" if plane.kind == "xy" else "z"
    return hv.Dimension("x", label="x", unit="m"), hv.Dimension(second, label=second, unit="m")


def _bounds(plane):
    (u0, u1), (v0, v1) = plane.u, plane.v
    du, dv = (u1 - u0) / (plane.n - 1), (v1 - v0) / (plane.n - 1)
    return (u0 - du / 2, v0 - dv / 2, u1 + du / 2, v1 + dv / 2)  # pixel edges, so centres sit on the grid


def map_image(values, plane, vdim):
    """A heatmap of ``values`` (n, n) over ``plane`` with hover showing x, y/z and the value."""
    return hv.Image(np.flipud(values), bounds=_bounds(plane), kdims=list(axes(plane)), vdims=[vdim])


def veil(observable, plane):
    """Grey overlay where Γ is structurally rank-deficient (fully transparent elsewhere)."""
    mask = (~observable).astype(float)
    return hv.Image(np.flipud(mask), bounds=_bounds(plane), kdims=list(axes(plane)),
                    vdims=[hv.Dimension("unobservable", label="structurally unobservable")]).opts(
        cmap=["#ffffff00", VEIL], clim=(0, 1), alpha=0.55, colorbar=False, tools=[])


# -- a layout's CRLB map (the Layout design and Track tabs)

@dataclass(frozen=True)
class Design:
    """CRLB maps of the custom layout over the x–y plane at the target depth."""

    plane: core.Plane
    stations: np.ndarray  # (S, 3), m
    errors: object  # core.CrlbErrors with (n, n) arrays


# -- layout design tab --------------------------------------------------------------------------

def _errors(d, quantity):
    values = getattr(d.errors, ERROR_QUANTITIES[quantity])
    return np.where(np.isfinite(values), values, np.nan)


def error_clim(d, quantity="3-D position error (m)"):
    """(low, high) of a design's error map: 1–99 % of its finite values; (1, 10) if none."""
    err = _errors(d, quantity)
    finite = err[np.isfinite(err)]
    return (float(np.percentile(finite, 1)), float(np.percentile(finite, 99))) if finite.size else (1, 10)


def common_clim(*designs, quantity="3-D position error (m)"):
    """One colour range covering the error maps of several designs (to compare them side by side)."""
    lims = [error_clim(d, quantity) for d in designs]
    return (min(lo for lo, _ in lims), max(hi for _, hi in lims))


#: The Layout design map's frame side (px): beside the station table (~600 px high) it leaves
#: no blank under it; it was 320 px with ~200 px blank under it at every window size.
DESIGN_MAP_PX = 460


def to_scale(xlim, ylim, longest):
    """Frame width and height (px) drawing the ranges ``xlim`` and ``ylim`` (m) at one scale,
    the longer span ``longest`` px: equal px per metre in x and y, so a course's angle on the
    screen is its true angle (a responsive frame drew the Track tab's plan at 1.333 px/m in x
    and 0.785 in y: a 25° track looked like 15°)."""
    xs, ys = float(xlim[1] - xlim[0]), float(ylim[1] - ylim[0])
    if not (xs > 0 and ys > 0):
        raise ValueError(f"empty range: x {xlim}, y {ylim}")
    scale = longest / max(xs, ys)
    return dict(frame_width=int(round(xs * scale)), frame_height=int(round(ys * scale)))


def error_map(d, title, quantity="3-D position error (m)", clim=None, size=DESIGN_MAP_PX):
    """A CRLB error (1σ, log colour scale) of a layout over the x–y plane; ``clim`` the colour
    range (default :func:`error_clim`), ``size`` the frame's longer side in pixels (to scale)."""
    err = _errors(d, quantity)
    label, unit = quantity.rsplit(" (", 1)
    vdim = hv.Dimension("error", label=label, unit=unit.rstrip(")"))
    img = map_image(err, d.plane, vdim).opts(
        cmap="viridis_r", logz=True, clim=clim or error_clim(d, quantity), colorbar=True,
        clabel=f"CRLB {quantity}, log scale", tools=["hover"], clipping_colors={"NaN": "white"},
        **to_scale(d.plane.u, d.plane.v, size), framewise=True, title=title)
    return img * veil(~veiled(d), d.plane) * runaway_layer(d)


def veiled(d):
    """Where a design's map is veiled grey (bool (n, n), rows along y): rank-deficient Γ, with a
    finite position error."""
    return ~(d.errors.observable | np.isnan(d.errors.position))


def runaway_marks(d, k=1):
    """Where a design's map gets a white dot (bool (k n, k n)): the 3-D position CRLB exceeds
    RUNAWAY_LIMIT × the range to the nearest station (:func:`app.kit.runaway.runaway`), each point
    repeated k × k times (a coarse preview's marks on a finer grid), on the dots' pattern."""
    far = _finer(runaway(d.plane, d.stations, d.errors.position, d.errors.observable), k)
    return far & runaway_dots(far.shape)


def _finer(mask, k):
    return np.repeat(np.repeat(mask, k, axis=0), k, axis=1) if k > 1 else mask


#: Colours of :func:`preview_arrays`' marks 0, 1, 2: none, the veil, a runaway dot (the
#: layers' colours at their alphas, 0.55 and 0.7).
MARK_COLOURS = ("#ffffff00", VEIL + "8c", "#ffffffb3")


def preview_arrays(d, quantity, fine=None):
    """A design's map as the Layout design tab's preview layers draw it, colour-mapped in the
    browser (app/tabs/design/live.py): (error image data, marks image data, colour range). The error
    is float32 (NaN where infinite), the marks uint8 (0 none, 1 veil, 2 runaway dot; the
    veil and the dots never overlap: a dot needs a full rank); rows along y from the bottom,
    as Bokeh's Image draws them. ``fine``: the exact map's points per side: the marks are
    drawn on a grid about as fine (each preview point k × k times), so that the dots are the
    exact map's size (on the preview's grid, 40 × 40, they were 45 m squares)."""
    err = _errors(d, quantity).astype(np.float32)
    k = max(1, int(round(fine / d.plane.n))) if fine else 1
    marks = np.zeros((err.shape[0] * k, err.shape[1] * k), dtype=np.uint8)
    marks[_finer(veiled(d), k)] = 1
    marks[runaway_marks(d, k)] = 2
    x0, y0, x1, y1 = _bounds(d.plane)
    where = dict(x=[x0], y=[y0], dw=[x1 - x0], dh=[y1 - y0])
    return dict(image=[err], **where), dict(image=[marks], **where), error_clim(d, quantity)


def runaway_layer(d):
    """White dots where the design's 3-D position CRLB exceeds RUNAWAY_LIMIT × the range to
    the nearest station (:func:`runaway_marks`; the same marks as the Maps tab's)."""
    hatch = runaway_marks(d)
    label = f"CRLB > {RUNAWAY_LIMIT:.0%} of range"
    return hv.Image(np.flipud(hatch.astype(float)), bounds=_bounds(d.plane), kdims=list(axes(d.plane)),
                    vdims=[hv.Dimension("runaway", label=label)]).opts(
        cmap=["#ffffff00", "#ffffff"], clim=(0, 1), alpha=0.7, colorbar=False, tools=[])


def station_layer(stations, editable=False):
    """Station markers (x, y) with their depth z as a value; ``editable``: the point-draw tool
    (of a PointDraw stream on this layer) is active. No hover of their own: the map's tooltip is
    the one shown over a station (two overlapped), and the table lists x, y, z."""
    data = {"x": [s[0] for s in stations], "y": [s[1] for s in stations], "z": [s[2] for s in stations]}
    points = hv.Points(data, kdims=[hv.Dimension("x", unit="m"), hv.Dimension("y", unit="m")],
                       vdims=[hv.Dimension("z", unit="m")]).opts(
        marker="triangle", size=14, color="white", line_color="black", line_width=1.5)
    return points.opts(active_tools=["point_draw"]) if editable else points


def error_ellipse(errors, x, y, extent, range_m=None, water_depth=None):
    """The 1-σ horizontal error ellipse at (x, y), drawn ×k so that it is visible; and its text
    (saying so when the 3-D error exceeds RUNAWAY_LIMIT × ``range_m``, the range to the nearest
    station, m, and when the depth error exceeds ``water_depth``, the layered sea's D, m)."""
    if errors is None or not bool(errors.observable):
        return hv.Ellipse(0, 0, 0).opts(alpha=0), "Click on the map (away from a station) for the error ellipse there."
    a, b = float(errors.semi_major), float(errors.semi_minor)
    k = max(1.0, 0.04 * extent / a) if a > 0 else 1.0
    ell = hv.Ellipse(x, y, (2 * a * k, 2 * b * k), orientation=np.deg2rad(float(errors.orientation)))
    text = (f"Target at ({x:.0f}, {y:.0f}) m: 1-σ horizontal error ellipse {a:.3g} m × {b:.3g} m "
            f"at {float(errors.orientation):.0f}° from +x (drawn ×{k:.3g}); depth error "
            f"{float(errors.sigma_z):.3g} m; speed error {float(errors.sigma_speed):.3g} m/s; "
            f"3-D position error {float(errors.position):.3g} m.")
    if water_depth is not None and float(errors.sigma_z) > water_depth:
        # "a depth error of 1.24e+04 m in 8.4 m of water" was printed unflagged
        text += (f" The depth error is larger than the water column ({water_depth:g} m): these "
                 "measurements do not tell the depth; only the sea bounds it.")
    if range_m is not None and float(errors.position) > RUNAWAY_LIMIT * range_m:
        text += (f" That is over {RUNAWAY_LIMIT:.0%} of the range to the nearest station "
                 f"({range_m:.3g} m): the linearised bound does not predict a tracker's error here "
                 "(far-field runaway; dotted white on the map).")
    return ell.opts(color="red", line_width=2), text


def spacing_plot(sp):
    """Criterion vs spacing d for the dual layout, optimum marked, the paper's d = 15 m shown."""
    r = sp.result
    curve = hv.Curve((r.d_values, r.curve), hv.Dimension("d", label="station spacing d", unit="m"),
                     hv.Dimension("criterion", label=sp.label)).opts(tools=["hover"], color="#1f5f8b")
    best = hv.Scatter([(r.d, r.value)], "d", "criterion").opts(size=12, color="red", marker="star")
    paper = hv.VLine(15.0).opts(color="grey", line_dash="dashed")
    edge = " (at the edge of the scanned range)" if r.at_bound else ""
    return (curve * best * paper).opts(
        frame_width=380, frame_height=260, title=f"Best d = {r.d:.1f} m{edge}; dashed: paper's d = 15 m")
