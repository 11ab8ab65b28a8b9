"""The Maps tab's downloads: the three maps as an xarray Dataset, CSV and NetCDF."""

from __future__ import annotations

import io
import re

import xarray as xr

from app.kit.views import axes

from .compute import Panels


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


def _names_unit(label, unit):
    """Whether ``label`` ends by naming ``unit`` in its parentheses ("(1σ, m)", "(m)")."""
    return re.search(r"[(,]\s*" + re.escape(unit) + r"\)$", label) is not None


def to_csv(p: Panels, params: dict) -> io.StringIO:
    """Tidy CSV, one row per grid point; the scenario as leading '#' comment lines."""
    ds = to_dataset(p, params)
    df = ds.to_dataframe().reset_index()
    # columns say what they hold (they were bare A, B, difference): measure and unit
    # (not when the label already ends with it: "CRLB position error (1σ, m) (m)")
    unit = f" ({p.value_unit})" if p.value_unit and not _names_unit(p.value_label, p.value_unit) else ""
    df = df.rename(columns={"x": "x (m)", ds["A"].dims[0]: f"{ds['A'].dims[0]} (m)",
                            "A": f"A: {p.value_label}{unit}", "B": f"B: {p.value_label}{unit}",
                            "difference": f"B vs A: {p.diff_label}"})
    buf = io.StringIO()
    for k, v in ds.attrs.items():
        buf.write(f"# {k} = {v}\n")
    df.to_csv(buf, index=False)
    buf.seek(0)
    return buf


def download_name(p: Panels, ext):
    """A download's file name after the scenario (the saved PNGs' stem), e.g. ``fig_5_x_y_log10_det.csv``."""
    return f"{p.filename}.{ext}"


def to_netcdf(p: Panels, params: dict) -> io.BytesIO:
    """NetCDF-4 (h5netcdf) bytes of :func:`to_dataset`."""
    buf = io.BytesIO()
    to_dataset(p, params).to_netcdf(buf, engine="h5netcdf")
    buf.seek(0)
    return buf
