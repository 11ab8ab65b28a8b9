"""Sweep any two scenario parameters and tabulate one measure: a tidy CSV and a heatmap PNG.

    python -m core.sweep --x d=2:100:25 --y z=100:400:16 --measure d_optimal --out DIR
    python -m core.sweep --x d=2:200:20 --y ratio=0.25:8:12 --measure mean_dopt \\
        --region=-300:300:-300:300:21 --out DIR
    python -m core.sweep --x d=5,10,20,40 --y noise=1e-8:1e-6:5:log --measure crlb_semi_major \\
        --set x=100 --set y=-50 --out DIR

Axis syntax: ``NAME=START:STOP:COUNT`` (evenly spaced; append ``:log`` for log spacing) or
``NAME=V1,V2,…``. Parameters not swept take their ``--set NAME=VALUE`` or default (the paper's
scenario, spec §5): see :data:`PARAMETERS`. ``ratio`` sets Ph = ratio · Pv.

``--sensor`` (``sensor`` in the settings of :func:`evaluate` and :func:`run`) is the measurement
model, one :class:`core.Sensor` built per cell: ``E`` (electric, the default), ``B``
(magnetometer), ``G`` (gradiometer), ``BG`` (both). The magnetic kinds take the moment vector
``mx``, ``my``, ``mz`` (A·m²) instead of Ph, Pv, noise in nT (``noise``, B) and nT/m
(``noise_g``, G; BG uses both; defaults :data:`core.MAGNETIC_NOISE`) and the gradiometer's
``baseline`` (m, 0 = the point tensor); ``sigma``, ``--model`` and ``--sea-depth`` are electric.
The paper's square rule (``log10_det``) is electric only.

Point measures are evaluated for one target at (x, y, z); region measures (``mean_dopt``,
``worst_dopt``, ``area_crlb``, see :func:`core.layout_criterion`) over the x–y rectangle
``--region=XMIN:XMAX:YMIN:YMAX:N`` at target depth z; x and y are then not used. (Write it
with ``=``: argparse takes a value starting with a minus sign for an option.)

Writes ``DIR/sweep.csv`` (one row per (x, y) cell: both parameters and the measure; ``inf``,
``-inf`` where unobservable, ``nan`` where undefined, e.g. a target on a station),
``DIR/sweep.png`` (heatmap; grey cells are not finite) and ``DIR/sweep.json`` (the settings).

Rows of the grid go to ``--workers`` processes (default 2) with one numba thread each, or, with
``--scheduler tcp://HOST:8786``, to a ``dask.distributed`` cluster (:func:`core.dask_backend.run_calls`;
why the local pool stays the default: docs/dask.md). The values are the same bit for bit
either way.
"""

from __future__ import annotations

import csv
import json
import os
import sys
import textwrap
from pathlib import Path

import numpy as np
from tqdm import tqdm

import core

from .. import dask_backend
from ..sweep import (DEPTHS, PARAMETERS, POSITIVE, SENSORS, SWEEP_MEASURES, default_noise,
                     evaluate, parse_axis, parse_region, run, unused_parameters)
from . import ArgumentParser, figure, save

def write_csv(path, xname, xvals, yname, yvals, measure, values):
    """Tidy table: one row per cell, columns (xname, yname, measure)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([xname, yname, measure])
        for i, yv in enumerate(yvals):
            for j, xv in enumerate(xvals):
                w.writerow([repr(float(xv)), repr(float(yv)), repr(float(values[i, j]))])


def _axis_label(name):
    unit = PARAMETERS[name][1]
    return f"{name} — {PARAMETERS[name][2]}" + (f" ({unit})" if unit else "")


def write_heatmap(path, xname, xvals, yname, yvals, measure, values, title):
    """Heatmap PNG (matplotlib Agg); non-finite cells grey."""
    label, unit, _ = SWEEP_MEASURES[measure]
    fig, ax = figure(figsize=(7, 5), dpi=110)
    ax.set_facecolor("0.8")  # shows through masked (non-finite) cells
    masked = np.ma.masked_invalid(values)
    if masked.count():
        mesh = ax.pcolormesh(xvals, yvals, masked, shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label=label + (f" ({unit})" if unit else ""))
    ax.set_xlabel(_axis_label(xname))
    ax.set_ylabel(_axis_label(yname))
    if xname == "noise":
        ax.set_xscale("log")
    if yname == "noise":
        ax.set_yscale("log")
    ax.set_title("\n".join(textwrap.wrap(title, 95, replace_whitespace=False))
                 + "\ngrey: not finite (unobservable or on a station)", fontsize=7)
    save(fig, path)


def build_parser():
    p = ArgumentParser(
        prog="python -m core.sweep",
        description="Sweep two scenario parameters; write a tidy CSV and a heatmap PNG.",
        epilog="parameters: " + "; ".join(f"{k} ({v[1] or '-'}, default {v[0]}): {v[2]}"
                                          for k, v in PARAMETERS.items()),
    )
    p.add_argument("--x", required=True, help="x axis: NAME=START:STOP:COUNT[:log] or NAME=V1,V2,…")
    p.add_argument("--y", required=True, help="y axis, same syntax")
    p.add_argument("--measure", default="d_optimal", choices=list(SWEEP_MEASURES))
    p.add_argument("--out", required=True, help="output directory (created)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="fix a parameter that is not swept (repeatable)")
    p.add_argument("--layout", default="line", choices=["line", "triangle", "square"],
                   help="station layout scaled by d (default: line, the paper's dual for N=2)")
    p.add_argument("--stations", type=int, default=2, help="number of stations N, 1..8 (default 2)")
    p.add_argument("--sensor", default="E", choices=list(SENSORS),
                   help="sensor kind: E electric (default), B magnetometer, G gradiometer, BG both "
                        "(magnetic kinds: moments mx, my, mz in A·m², noise in nT, noise_g in nT/m)")
    p.add_argument("--model", default="exact", choices=["exact", "paper"])
    p.add_argument("--sea-depth", type=float, default=None, metavar="D",
                   help="layered sea of depth D (m; z is depth, stations and targets in 0..D); "
                        "default: the whole space")
    p.add_argument("--seabed-sigma", type=float, default=1.0,
                   help="seabed conductivity (S/m, ≥ 0) with --sea-depth (default 1.0)")
    p.add_argument("--steps", type=int, default=3, help="instants N of the all-rows Γ (default 3)")
    p.add_argument("--region", default="-300:300:-300:300:21",
                   help="region measures: --region=XMIN:XMAX:YMIN:YMAX:N (m, points) at target depth z")
    p.add_argument("--threshold", type=float, default=10.0, help="area_crlb threshold (m)")
    p.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--no-progress", action="store_true", help="hide the tqdm progress bar")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the dask.distributed cluster at ADDRESS, e.g. tcp://HOST:8786 "
                        "(needs the [dask] extra; default: local worker processes)")
    p.add_argument("--connect-timeout", type=float, default=10.0, metavar="SECONDS",
                   help="--scheduler: seconds to wait for the scheduler and a worker (default 10)")
    return p


def main(argv=None):
    """Entry point; returns the process exit status (0 ok, 1 scheduler unreachable, 2 bad
    arguments)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        xaxis, yaxis = parse_axis(args.x), parse_axis(args.y)
        if xaxis[0] == yaxis[0]:
            raise ValueError(f"--x and --y must be different parameters; both are {xaxis[0]!r}")
        if {"Ph", "ratio"} <= {xaxis[0], yaxis[0]}:
            raise ValueError("sweep Ph or ratio (= Ph/Pv), not both")
        unused = unused_parameters(args.sensor)
        for name in [xaxis[0], yaxis[0]] + [item.split("=", 1)[0].strip() for item in args.set]:
            if name in unused:
                raise ValueError(f"parameter {name} does not apply to --sensor {args.sensor} "
                                 f"({'electric' if args.sensor == 'E' else 'magnetic'})")
        base = {k: v[0] for k, v in PARAMETERS.items()}
        base.update(default_noise(args.sensor))
        for item in args.set:
            name, vals = parse_axis(item)
            if vals.size != 1:
                raise ValueError(f"--set takes one value; got {item!r}")
            base[name] = float(vals[0])
        # the swept values, and the fixed ones of the parameters not swept (a swept parameter's
        # default is not used: z swept over 2…6 m in an 8.4 m sea is not refused for z = 120 m)
        given = (xaxis, yaxis, *((k, [v]) for k, v in base.items()
                                 if v is not None and k not in (xaxis[0], yaxis[0])))
        for name, vals in given:
            if name in POSITIVE and np.any(np.asarray(vals) <= 0):
                raise ValueError(f"parameter {name} must be > 0 ({PARAMETERS[name][1]}); "
                                 f"got {np.asarray(vals).min():g}")
        for name, vals in given:
            if name in DEPTHS and np.min(vals) < 0:
                raise ValueError(f"parameter {name} ({PARAMETERS[name][2]}) = {np.min(vals):g} m is "
                                 "above the sea surface: depths are measured down from it (≥ 0)")
        if args.workers < 1:
            raise ValueError(f"--workers must be ≥ 1; got {args.workers}")
        settings = {"measure": args.measure, "layout": args.layout, "stations": args.stations,
                    "sensor": args.sensor, "model": args.model, "steps": args.steps, "sea_depth": args.sea_depth,
                    "seabed_sigma": args.seabed_sigma,
                    "region": parse_region(args.region), "threshold": args.threshold}
        # Check one cell here, so that bad input fails fast with its message, not in a worker.
        evaluate(dict(base, **{xaxis[0]: xaxis[1][0], yaxis[0]: yaxis[1][0]}), settings)
        # ... which accepted the sea (--sea-depth); the other cells' depths must be in it too.
        for name, vals in given:
            if name in DEPTHS and args.sea_depth is not None and np.max(vals) > args.sea_depth:
                raise ValueError(f"parameter {name} ({PARAMETERS[name][2]}) = {np.max(vals):g} m is "
                                 f"below the seabed: with --sea-depth {args.sea_depth:g} depths "
                                 f"lie in 0 … {args.sea_depth:g} m")
    except ValueError as exc:
        parser.error(str(exc))  # exits with status 2
    client = None
    if args.scheduler is not None:
        try:
            client = dask_backend.connect(args.scheduler, timeout=args.connect_timeout)
        except ValueError as exc:
            parser.error(str(exc))
        except (ConnectionError, ImportError) as exc:
            print(f"{parser.prog}: error: {exc}", file=sys.stderr)
            return 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    bar = tqdm(total=xaxis[1].size * yaxis[1].size, unit="cell", disable=args.no_progress,
               desc=f"{args.measure} over {xaxis[0]}×{yaxis[0]}")
    try:
        values = run(xaxis, yaxis, settings, base, workers=args.workers, progress=bar.update,
                     client=client)
    finally:
        bar.close()
        if client is not None:
            client.close()
    write_csv(out / "sweep.csv", xaxis[0], xaxis[1], yaxis[0], yaxis[1], args.measure, values)
    unused = unused_parameters(args.sensor)
    fixed = {k: v for k, v in base.items()
             if k not in (xaxis[0], yaxis[0]) and k not in unused and v is not None}
    if SWEEP_MEASURES[args.measure][2]:  # region measures do not use the target's x, y
        fixed = {k: v for k, v in fixed.items() if k not in ("x", "y")}
    what = (f"{args.model} model" if args.sensor == "E"
            else f"sensor {args.sensor} ({core.KINDS[args.sensor][0]})")
    title = (f"{args.layout} layout, {args.stations} stations, {what}\n"
             + ", ".join(f"{k}={v:g}" for k, v in fixed.items()))
    write_heatmap(out / "sweep.png", xaxis[0], xaxis[1], yaxis[0], yaxis[1], args.measure,
                  values, title)
    (out / "sweep.json").write_text(json.dumps(
        dict(argv=list(sys.argv[1:] if argv is None else argv), fixed=fixed, **{
            k: (list(v) if isinstance(v, tuple) else v) for k, v in settings.items()}),
        indent=2, default=list))
    print(f"wrote {out / 'sweep.csv'} ({values.size} rows) and {out / 'sweep.png'}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())
