"""The three comparison maps' pixels and texts, worked out from :class:`app.tabs.maps.compute.Panels` with
numpy alone (no Bokeh model): what :mod:`app.tabs.maps.figures` sends to the page and what
:mod:`app.tabs.maps.export` draws into a PNG or PDF, so that both show the same numbers.

Colour ranges. An image is sent *normalised* to its colour range (0 at the low end, 1 at the high
end; :func:`normalised`), a preview as uint8 levels of it (:func:`quantised`); why, in
:mod:`app.tabs.maps.figures`. Veils are uint8 codes (:func:`veil_codes`), the same rectangle as the map.
:func:`prepare` does all of it off the event loop and returns a :class:`Prepared`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from bokeh.palettes import RdBu11, Viridis256

from app.kit.runaway import runaway_dots

from .compute import KIND_NAMES, Panels, colour_range

#: Veil codes of a pixel (the veil image): 0 observable, 1 and 2 unobservable (the two colours of
#: its stripes), 3 no value (on a station, or blank where the paper's Δ ≤ 0), 4 and 5 a CRLB
#: beyond RUNAWAY_LIMIT of the range (the linearised bound runs away: 4 its white dots, 5 between
#: them): see VEIL_PALETTE.
OK, VEIL_DARK, VEIL_LIGHT, NO_VALUE, RUNAWAY, RUNAWAY_GAP = 0, 1, 2, 3, 4, 5
#: Unobservable points are striped grey, opaque enough that the round-off beneath is not read as
#: colour; points with no value are left to the image's own white (NaN); runaway points are
#: dotted white (:func:`runaway_dots`), the colour beneath still readable. Distinct by design:
#: runaway was hatched the other way, and two kinds of diagonal stripes were confused (issue 25).
VEIL_PALETTE = ("#00000000", "#6b6b6bdd", "#b4b4b4dd", "#00000000", "#ffffffb0", "#00000000")
NAN_COLOUR = "#ffffff"
#: A preview image's levels (app/tabs/maps/live.py): 0 … PREVIEW_TOP over the colour range, PREVIEW_NAN
#: where there is no value (drawn in NAN_COLOUR, the preview mapper's ``high_color``).
PREVIEW_TOP, PREVIEW_NAN = 254, 255
STRIPE = 6  # pixels of the map grid per stripe of the veil


def exaggeration(plane):
    """The vertical exaggeration an x–z section is drawn with: 1, 2, 5, 10, 20, … nearest (in
    log) to its width over its depth, never below 1 (1 for an x–y map: a metre is a metre)."""
    if plane.kind != "xz":
        return 1
    ratio = (plane.u[1] - plane.u[0]) / max(plane.v[1] - plane.v[0], 1e-9)
    if ratio <= 1.5:
        return 1
    nice = [m * 10 ** k for k in range(0, 8) for m in (1, 2, 5)]
    return min(nice, key=lambda e: abs(np.log(e / ratio)))


def _symmetric(values):
    finite = values[np.isfinite(values)]
    m = float(np.percentile(np.abs(finite), 99.5)) if finite.size else 1.0
    return (-m or -1.0, m or 1.0)


def _diff_colours(p: Panels):
    """The difference map's colour range, and whether it is the paper's log10(|B| − |A|)
    (sequential palette) rather than a signed log-ratio (diverging, symmetric range)."""
    paper_diff = p.diff_label.startswith("log10(|B|")
    return (colour_range(p.diff) if paper_diff else _symmetric(p.diff)), paper_diff


def _maps(p: Panels):
    """[(values shown, observable, stations (S, 2), title)] of the three maps, and the axis names."""
    col = 1 if p.plane.kind == "xy" else 2
    maps = []
    for which, res in enumerate((p.a, p.b)):
        title = p.titles[which] + (" — round-off" if not res.observable.any() else "")
        maps.append((p.shown(which), res.observable, p.stations[which][:, [0, col]], title))
    both = np.unique(np.vstack(p.stations), axis=0)
    maps.append((p.diff, p.a.observable & p.b.observable, both[:, [0, col]], p.titles[2]))
    return maps, ("x", "y" if p.plane.kind == "xy" else "z")


#: The diverging palette of a signed comparison, low to high: B better is blue, B worse red,
#: whichever way the measure runs (RdBu11 runs blue to red).
B_BETTER_LOW, B_BETTER_HIGH = RdBu11, RdBu11[::-1]


def ranges(p: Panels):
    """[(low, high, palette)] of each map's colour scale: A and B share theirs.

    A signed difference is blue where B is better and red where it is worse for every measure:
    lower is better for the CRLB (log10 σ_B/σ_A < 0), higher for the others (it was one palette
    for all, so "B better" was red on the CRLB map and blue on the others)."""
    diff_range, paper_diff = _diff_colours(p)
    value = (p.clim[0], p.clim[1], Viridis256[::-1] if p.log_scale else Viridis256)  # CRLB: low good
    signed = B_BETTER_LOW if p.measure == "crlb_position" else B_BETTER_HIGH
    diff = (diff_range[0], diff_range[1], Viridis256 if paper_diff else signed)
    return [value, value, diff]


def contents(p: Panels):
    """What each map shows: [(values, observable, stations (S, 2), title)], labels and ranges.

    Pure: the numbers :func:`fill` writes, kept separate so they can be tested without Bokeh.
    """
    maps, axes = _maps(p)
    diff_range, paper_diff = _diff_colours(p)
    return maps, axes, p.clim, diff_range, paper_diff


def normalised(values, low, high):
    """``values`` as sent to the browser: (v − low) / (high − low) in float32, NaN kept."""
    return ((np.asarray(values, dtype=float) - low) / (high - low)).astype(np.float32)


def quantised(values, low, high):
    """``values`` as a preview sends them: uint8 levels 0 … PREVIEW_TOP over ``low`` … ``high``
    (clipped, as the colour mapper clips), PREVIEW_NAN where NaN; a quarter of float32's bytes."""
    v = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        level = np.rint(np.clip((v - low) / (high - low), 0.0, 1.0) * PREVIEW_TOP)
    return np.where(np.isfinite(v), level, PREVIEW_NAN).astype(np.uint8)


def veil_codes(observable, values, runaway=None):
    """The veil image (uint8 codes, see :data:`VEIL_PALETTE`): diagonal stripes where the point
    is unobservable, NO_VALUE where it is observable but has no value, dots (:func:`runaway_dots`)
    where ``runaway`` (bool, optional) flags it, OK elsewhere."""
    n_v, n_u = observable.shape
    i, j = np.arange(n_v)[:, None], np.arange(n_u)[None, :]
    stripes = ((i + j) // STRIPE) % 2
    good = np.where(np.isfinite(values), OK, NO_VALUE)
    if runaway is not None:
        good = np.where(runaway & np.isfinite(values),
                        np.where(runaway_dots(observable.shape), RUNAWAY, RUNAWAY_GAP), good)
    return np.where(observable, good, VEIL_DARK + stripes).astype(np.uint8)


def wrapped(text, width=50):
    """``text`` in lines of at most ``width`` characters, broken after commas (a Bokeh title
    does not wrap by itself: a long caption was cut at the plot's edge; 50 fits a map at a
    1280 px wide screen with the sidebar open)."""
    lines, line = [], ""
    for part in text.split(", "):
        if line and len(line) + 2 + len(part) > width:
            lines.append(line + ",")
            line = part
        else:
            line = f"{line}, {part}" if line else part
    return "\n".join(lines + [line])


def veiled_text(p: Panels, which):
    """What map ``which`` (0 A, 1 B, 2 difference) is when it is unobservable at every point
    (said inside its frame), else ''."""
    a_none, b_none = (not res.observable.any() for res in (p.a, p.b))
    # short lines: a Label does not wrap, and a map is ~130 px wide at a 1280 px screen
    if which == 2:
        if not (a_none or b_none):
            return ""
        who = "A and B are" if a_none and b_none else "A is" if a_none else "B is"
        return f"no difference:\n{who} unobservable\nat every point"
    if not (a_none, b_none)[which]:
        return ""
    if "rank 6" in p.unobservable[which]:
        return ("unobservable at every\npoint (rank 6 of 7):\none station cannot\n"
                "tell range from\nsource strength")
    kind = p.kinds[which]
    if "rank 7 of 8" in p.unobservable[which]:  # one magnetometer or gradiometer (spec §11)
        return (f"unobservable at every\npoint (rank 7 of 8):\none {KIND_NAMES[kind][0]}\n"
                "cannot tell range\nfrom moment strength")
    return f"unobservable at every\npoint (rank < {7 if kind == 'E' else 8}):\ncolours are round-off"


def geometry(plane):
    """x, y, dw, dh of the images: pixel edges, so that pixel centres sit on the plane's grid."""
    (u0, u1), (v0, v1) = plane.u, plane.v
    du, dv = (u1 - u0) / (plane.n - 1), (v1 - v0) / (plane.n - 1)
    return dict(x=[u0 - du / 2], y=[v0 - dv / 2], dw=[u1 - u0 + du], dh=[v1 - v0 + dv])


def view_box(p: Panels):
    """(x start, x end, second-axis start, end) of a new view: the map and every station, with a
    margin so a station's marker is never cut; the x–z plane has depth increasing downwards."""
    g = geometry(p.plane)
    col = 1 if p.plane.kind == "xy" else 2
    st = np.vstack(p.stations)
    u0, u1 = min(g["x"][0], st[:, 0].min()), max(g["x"][0] + g["dw"][0], st[:, 0].max())
    v0, v1 = min(g["y"][0], st[:, col].min()), max(g["y"][0] + g["dh"][0], st[:, col].max())
    mu, mv = 0.03 * (u1 - u0), 0.03 * (v1 - v0)
    box_u = (u0 - mu if st[:, 0].min() - mu < g["x"][0] else u0,
             u1 + mu if st[:, 0].max() + mu > g["x"][0] + g["dw"][0] else u1)
    lo = v0 - mv if st[:, col].min() - mv < g["y"][0] else v0
    hi = v1 + mv if st[:, col].max() + mv > g["y"][0] + g["dh"][0] else v1
    return (*box_u, *((hi, lo) if p.plane.kind == "xz" else (lo, hi)))


@dataclass(frozen=True)
class Prepared:
    """The arrays :func:`set_maps` sends, worked out beforehand (on a worker thread: no numpy work
    on the server's event loop while maps are drawn)."""

    panels: Panels
    maps: list  # [(values shown, observable, stations (S, 2), title)] of A, B, difference
    axes: tuple  # ("x", "y" or "z")
    ranges: list  # [(low, high, palette)] of each map
    images: tuple  # float32, normalised to each map's range (a preview's: uint8, :func:`quantised`)
    veils: tuple  # uint8 veil codes
    preview: bool = False  # drawn in the preview layer while a slider is dragged (app/tabs/maps/live.py)


def prepare(p: Panels, preview=False) -> Prepared:
    """Everything numeric that drawing ``p`` needs (pure; thread-safe). ``preview``: the images
    as uint8 levels for the preview layer (:func:`quantised`)."""
    maps, axes = _maps(p)
    scales = ranges(p)
    encode = quantised if preview else normalised
    images = tuple(encode(values, low, high) for (values, *_), (low, high, _) in zip(maps, scales))
    far = p.runaway or (None, None, None)
    veils = tuple(veil_codes(observable, values, r) for (values, observable, *_), r in zip(maps, far))
    return Prepared(panels=p, maps=maps, axes=axes, ranges=scales, images=images, veils=veils,
                    preview=preview)


_SUPERSCRIPT = str.maketrans("0123456789-", "\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b")


def tick_texts(ticks, log):
    """The colour bar's labels of ``ticks`` as :data:`app.tabs.maps.figures._TICK_JS` writes them (the PNG export's
    too): plain numbers; on a log10-metre bar metres, all as plain numbers ("3.2", "100") or,
    when one of them is ≥ 10⁴ or < 10⁻² m, all as powers of ten ("10²", "3×10³", "10⁴")."""
    if not log:
        return [f"{float(f'{t:.6g}'):g}".replace("-", "\u2212") for t in ticks]
    metres = [10.0 ** t for t in ticks]
    if not any(m >= 1e4 or m < 1e-2 for m in metres):
        return [f"{float(f'{m:.2g}'):g}" for m in metres]
    out = []
    for m in metres:
        c, e = f"{m:.0e}".split("e")
        out.append(("" if c == "1" else c + "\u00d7") + "10" + str(int(e)).translate(_SUPERSCRIPT))
    return out
