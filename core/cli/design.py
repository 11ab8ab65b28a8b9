"""Design a survey layout: stations beside fixed ones, outside forbidden zones, for a criterion;
write the layout, its maps and a CSV (issue 49, spec §13; docs/survey-design.md).

    python -m core.design --out DIR --new 4 --fixed=-200,0,100 --fixed=200,-200,100 \\
        --zone="-250,-250;-150,-250;-150,-100" --min-spacing 40 --criterion area_crlb \\
        --threshold 10 --region=-300:300:-300:300:31
    python -m core.design --out DIR --kind square --count --n-max 8 --criterion mean_crlb

``--zone`` is one forbidden polygon, its x–y vertices (m) ``x,y`` separated by ``;``;
``--fixed`` one existing station ``x,y,z`` (m); both repeat. ``--depth-band`` is ``ZMIN:ZMAX``
(m), ``seabed`` or ``seabed:HEIGHT`` (with ``--sea-depth``). Write values that start with a
minus sign with ``=`` (argparse takes them for options otherwise).

Writes ``DIR/layout.csv`` (one row per station: x, y, z in m, fixed or new, the coverage left
without it), ``DIR/maps.nc`` (NetCDF-4: the CRLB position error map, the worst single-loss map,
the station behind it and the map without each station, in m, over the region's grid),
``DIR/design.json`` (the problem, the criterion's value and unit) and, with ``--count``,
``DIR/count.csv`` (the best criterion for N = fixed + 1 … n_max, the knee marked). Bad input
(a self-intersecting zone, a fixed station in a zone or outside the band, a minimum spacing
the fixed stations break, too many stations, no room) is refused, its message naming the
station or zone, exit status 2, before anything is written.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

import core

from . import ArgumentParser

PROG = "python -m core.design"


def _floats(text, what, count=None):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"{what} must be numbers separated by commas; got {text!r}") from None
    if count is not None and len(values) not in np.atleast_1d(count):
        raise ValueError(f"{what} must have {count} numbers; got {text!r}")
    return values


def _zone(text):
    return [_floats(v, "a --zone vertex", 2) for v in text.split(";") if v.strip()]


def _band(text):
    if text is None:
        return None
    if text.startswith("seabed"):
        return ("seabed", float(text.split(":")[1])) if ":" in text else "seabed"
    lo, _, hi = text.partition(":")
    return (float(lo), float(hi))


def _region(text):
    parts = text.split(":")
    if len(parts) != 5:
        raise ValueError(f"--region must be XMIN:XMAX:YMIN:YMAX:N; got {text!r}")
    x0, x1, y0, y1 = map(float, parts[:4])
    return (x0, x1), (y0, y1), int(parts[4])


def parser():
    p = ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--kind", default="free", choices=list(core.LAYOUTS),
                   help="the new stations' layout (default free)")
    p.add_argument("--new", type=int, default=2, help="number of new stations (default 2)")
    p.add_argument("--fixed", action="append", default=[], metavar="X,Y,Z",
                   help="an existing station (m); repeat")
    p.add_argument("--zone", action="append", default=[], metavar="X,Y;X,Y;X,Y",
                   help="a forbidden polygon (m); repeat")
    p.add_argument("--depth-band", default=None, metavar="ZMIN:ZMAX|seabed[:H]")
    p.add_argument("--min-spacing", type=float, default=0.0, help="minimum spacing (m)")
    p.add_argument("--criterion", default="mean_dopt", choices=list(core.CRITERIA))
    p.add_argument("--threshold", type=float, default=10.0, help="coverage threshold T (m)")
    p.add_argument("--region", default="-300:300:-300:300:21", metavar="XMIN:XMAX:YMIN:YMAX:N")
    p.add_argument("--z", type=float, default=120.0, help="target depth (m)")
    p.add_argument("--h", type=float, default=100.0, help="the new stations' depth (m)")
    p.add_argument("--velocity", default="2,2", help="target vx,vy (m/s)")
    p.add_argument("--moments", default="100,20", help="Ph,Pv (A·m) or mx,my,mz (A·m²)")
    p.add_argument("--sensor", default="E", choices=list(core.KINDS))
    p.add_argument("--sea-depth", type=float, default=None, metavar="D",
                   help="a layered sea of depth D (m), electric")
    p.add_argument("--seabed-sigma", type=float, default=1.0, help="seabed conductivity (S/m)")
    p.add_argument("--steps", type=int, default=3, help="instants N of the all-rows Γ")
    p.add_argument("--maxfev", type=int, default=400, help="free layout: Powell's budget")
    p.add_argument("--count", action="store_true", help="also the stations-count curve")
    p.add_argument("--n-max", type=int, default=core.MAX_STATIONS, help="largest N of --count")
    p.add_argument("--share", type=float, default=0.05, help="knee share of --count")
    return p


def problem_of(args):
    """The core.LayoutProblem of the parsed arguments (ValueError on bad input)."""
    xr, yr, n = _region(args.region)
    sea = None if args.sea_depth is None else core.Sea(args.sea_depth, args.seabed_sigma)
    constraints = core.LayoutConstraints(
        fixed=[_floats(f, "--fixed", 3) for f in args.fixed] or (),
        zones=[_zone(z) for z in args.zone], depth_band=_band(args.depth_band),
        min_spacing=args.min_spacing)
    return core.LayoutProblem(
        core.Plane("xy", xr, yr, args.z, n), h=args.h, sensor=core.Sensor(args.sensor, sea=sea),
        velocity=tuple(_floats(args.velocity, "--velocity", 2)),
        moments=tuple(_floats(args.moments, "--moments", (2, 3))), criterion=args.criterion,
        threshold=args.threshold, steps=args.steps, constraints=constraints)


def write_maps(path, problem, stations):
    """The CRLB and loss maps (m) of a layout as NetCDF-4 (h5netcdf, as the Maps tab's file)."""
    import xarray as xr

    region = problem.region
    errors = core.crlb_maps(region, stations, velocity=problem.velocity,
                            moments=problem.moments, steps=problem.steps, sensor=problem.sensor)
    loss = core.station_loss(stations, problem)
    x, y = region.axes
    coords = {"y": y, "x": x, "station": np.arange(len(stations))}
    ds = xr.Dataset({
        "crlb_position": (("y", "x"), errors.position, {"units": "m"}),
        "worst_loss": (("y", "x"), loss.worst, {"units": "m"}),
        "worst_station": (("y", "x"), loss.worst_station),
        "loss": (("station", "y", "x"), loss.per_station, {"units": "m"}),
    }, coords=coords, attrs={"threshold_m": problem.threshold, "coverage_n1": loss.coverage_n1})
    ds.to_netcdf(path, engine="h5netcdf")
    return loss


def main(argv=None):
    p = parser()
    args = p.parse_args(argv)
    try:
        problem = problem_of(args)
        result = core.optimise_layout(args.kind, args.new, problem, maxfev=args.maxfev)
        count = core.station_count_curve(problem, kind=args.kind, n_max=args.n_max,
                                         share=args.share, maxfev=args.maxfev) if args.count else None
    except ValueError as err:
        p.error(str(err))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    loss = write_maps(out / "maps.nc", problem, result.stations)
    with open(out / "layout.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["station", "x_m", "y_m", "z_m", "role", "coverage_without"])
        for i, (x, y, z) in enumerate(result.stations):
            w.writerow([i, x, y, z, "fixed" if i < result.fixed else "new", loss.coverage_left[i]])
    label, unit = core.CRITERIA[args.criterion]
    (out / "design.json").write_text(json.dumps({
        "arguments": vars(args), "criterion": args.criterion, "label": label, "unit": unit,
        "value": result.value, "evaluations": result.nfev, "at_bound": list(result.at_bound),
        "stations": result.stations.tolist(), "fixed": result.fixed}, indent=2, default=str))
    if count is not None:
        with open(out / "count.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["n_stations", args.criterion, "knee"])
            for n, v in zip(count.n, count.value):
                w.writerow([int(n), v, int(n == count.knee)])
    print(f"{label}: {result.value:.6g} {unit}; {len(result.stations)} stations "
          f"({result.fixed} fixed) written to {out}")
    return 0
