"""Pure view functions: numbers from :mod:`app.compute` in, HoloViews elements out."""

from __future__ import annotations

import io

import holoviews as hv
import numpy as np
import xarray as xr

from .compute import Panels

hv.extension("bokeh", logo=False)

#: Colour maps: sequential for measures, diverging for signed comparisons.
SEQUENTIAL, DIVERGING, VEIL = "viridis", "RdBu_r", "#7f7f7f"


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


def stations_points(stations, plane):
    """Station markers; on an x–z plane the stations' depth is drawn."""
    col = 1 if plane.kind == "xy" else 2
    x, second = axes(plane)
    data = {"x": stations[:, 0], second.name: stations[:, col],
            "station": [f"station {i + 1}" for i in range(len(stations))]}
    return hv.Points(data, kdims=[x, second], vdims=["station"]).opts(
        marker="triangle", size=13, color="white", line_color="black", line_width=1.5,
        tools=["hover"])


def map_panel(p: Panels, which):
    """Overlay for map A (which=0), B (1) or the difference (2)."""
    if which < 2:
        res = (p.a, p.b)[which]
        vdim = hv.Dimension("value", label=p.value_label, unit=p.value_unit)
        img = map_image(res.value, p.plane, vdim).opts(cmap=SEQUENTIAL, clim=p.clim, clabel=p.value_label)
        observable, stations = res.observable, p.stations[which]
        title = p.titles[which]
        if not observable.any():
            title += " — round-off only"
    else:
        vdim = hv.Dimension("difference", label=p.diff_label)
        finite = p.diff[np.isfinite(p.diff)]
        if p.diff_label.startswith("log10(|B|"):
            lim = (float(np.percentile(finite, 0.5)), float(np.percentile(finite, 99.5))) if finite.size else (0, 1)
            cmap = SEQUENTIAL
        else:
            m = float(np.percentile(np.abs(finite), 99.5)) if finite.size else 1.0
            lim, cmap = (-m or -1.0, m or 1.0), DIVERGING
        img = map_image(p.diff, p.plane, vdim).opts(cmap=cmap, clim=lim, clabel=p.diff_label)
        observable = p.a.observable & p.b.observable
        stations = np.unique(np.vstack(p.stations), axis=0)
        title = p.titles[2]
    img = img.opts(colorbar=True, tools=["hover"], clipping_colors={"NaN": "white"},
                   frame_width=250, frame_height=250, framewise=True)
    return (img * veil(observable, p.plane) * stations_points(stations, p.plane)).opts(title=title)


def to_dataset(p: Panels, params: dict):
    """The maps as an xarray Dataset with units and the scenario in its attributes."""
    u, v = p.plane.axes
    x, second = axes(p.plane)
    coords = {second.name: (second.name, v, {"units": "m"}), "x": ("x", u, {"units": "m"})}
    dims = (second.name, "x")
    data = {
        "A": (dims, p.a.value, {"long_name": f"{p.titles[0]}: {p.value_label}", "units": p.value_unit}),
        "B": (dims, p.b.value, {"long_name": f"{p.titles[1]}: {p.value_label}", "units": p.value_unit}),
        "difference": (dims, p.diff, {"long_name": p.diff_label}),
        "A_observable": (dims, p.a.observable.astype("i1"), {"long_name": "1 where rank Γ is full"}),
        "B_observable": (dims, p.b.observable.astype("i1"), {"long_name": "1 where rank Γ is full"}),
    }
    attrs = {k: (v if isinstance(v, (int, float, str)) else str(v)) for k, v in params.items()}
    attrs["stations_A_m"] = str(p.stations[0].tolist())
    attrs["stations_B_m"] = str(p.stations[1].tolist())
    return xr.Dataset(data, coords=coords, attrs=attrs)


def to_csv(p: Panels, params: dict) -> io.StringIO:
    """Tidy CSV, one row per grid point; the scenario as leading '#' comment lines."""
    ds = to_dataset(p, params)
    df = ds.to_dataframe().reset_index()
    buf = io.StringIO()
    for k, v in ds.attrs.items():
        buf.write(f"# {k} = {v}\n")
    df.to_csv(buf, index=False)
    buf.seek(0)
    return buf


def to_netcdf(p: Panels, params: dict) -> io.BytesIO:
    """NetCDF-4 (h5netcdf) bytes of :func:`to_dataset`."""
    buf = io.BytesIO()
    to_dataset(p, params).to_netcdf(buf, engine="h5netcdf")
    buf.seek(0)
    return buf
