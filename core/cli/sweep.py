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

Both cores are used by processes, not threads: rows of the grid go to a
``concurrent.futures.ProcessPoolExecutor`` (``--workers``, default 2), and each worker pins
numba to one thread so the two levels of parallelism do not oversubscribe the cores.

Beyond one machine, ``--scheduler tcp://HOST:8786`` sends the rows to a ``dask.distributed``
cluster instead (``--workers`` is then unused; see :mod:`core.dask_backend` and docs/dask.md).
Without it the local process pool stays the default: it starts in a fraction of a second, needs
no optional dependency (dask is never imported), and on one machine a ``LocalCluster`` would
run the same rows in the same number of processes, after seconds of start-up. The values are
the same bit for bit either way (each cell is computed by the same code).
"""

from __future__ import annotations

import csv
import json
import math
import multiprocessing
import os
import sys
import textwrap
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numba
import numpy as np
from tqdm import tqdm

import core

from .. import dask_backend
from . import ArgumentParser

#: name -> (default, unit, description). Defaults: the paper's common scenario (spec §5).
PARAMETERS = {
    "d": (15.0, "m", "station spacing"),
    "h": (100.0, "m", "station depth"),
    "x": (30.0, "m", "target x (point measures)"),
    "y": (40.0, "m", "target y (point measures)"),
    "z": (120.0, "m", "target depth"),
    "Ph": (100.0, "A·m", "horizontal dipole moment"),
    "Pv": (20.0, "A·m", "vertical dipole moment"),
    "ratio": (None, "", "Ph / Pv (sets Ph = ratio·Pv)"),
    "speed": (2.0 * math.sqrt(2.0), "m/s", "target speed"),
    "heading": (45.0, "deg", "heading from +x towards +y"),
    "sigma": (4.0, "S/m", "sea conductivity"),
    "noise": (None, "V/m; nT", "sensor noise 1σ (electric 1e-7 V/m; magnetometer, nT)"),
    "T": (1.0, "s", "sample interval"),
    "mx": (1e3, "A·m²", "magnetic moment x (magnetic kinds)"),
    "my": (-2e3, "A·m²", "magnetic moment y (magnetic kinds)"),
    "mz": (5e2, "A·m²", "magnetic moment z (magnetic kinds)"),
    "noise_g": (None, "nT/m", "gradiometer noise 1σ (kinds G, BG)"),
    "baseline": (0.0, "m", "gradiometer baseline (0: point tensor)"),
}

#: Parameters that must be > 0.
POSITIVE = ("d", "speed", "sigma", "noise", "T", "ratio", "noise_g")
#: Depths (m, positive down, the sea surface at 0; spec §7): never negative, and within the water
#: column 0 … D with ``--sea-depth D``.
DEPTHS = ("h", "z")
#: Sensor kinds of ``--sensor`` (:data:`core.KINDS`).
SENSORS = tuple(core.KINDS)
#: Parameters of the electric kind only, and of the magnetic kinds only.
ELECTRIC_ONLY = ("Ph", "Pv", "ratio", "sigma")
MAGNETIC_ONLY = ("mx", "my", "mz", "noise_g", "baseline")

#: name -> (label, unit, region measure?).
SWEEP_MEASURES = {
    "d_optimal": ("D-optimal ½·log10 det F", "log10 of F's units", False),
    "log10_det": ("log10 |det Γ| (paper rule)", "log10 of Γ's units", False),
    "log10_eta": ("observability index log10 η (all rows)", "", False),
    "rank": ("structural rank of Γ (all rows)", "", False),
    "crlb_position": ("CRLB position error (1σ)", "m", False),
    "crlb_semi_major": ("CRLB horizontal ellipse semi-major (1σ)", "m", False),
    "crlb_semi_minor": ("CRLB horizontal ellipse semi-minor (1σ)", "m", False),
    "crlb_depth": ("CRLB depth error σz (1σ)", "m", False),
    "crlb_speed": ("CRLB speed error (1σ)", "m/s", False),
    "mean_dopt": ("mean D-optimal over region", "log10 of F's units", True),
    "worst_dopt": ("worst D-optimal over region", "log10 of F's units", True),
    "area_crlb": ("area fraction with CRLB position error < threshold", "", True),
}


def parse_axis(text):
    """``NAME=START:STOP:COUNT[:log]`` or ``NAME=V1,V2,…`` -> (name, values (K,)).

    Raises
    ------
    ValueError
        Unknown parameter, malformed range, COUNT < 1, or non-finite values.
    """
    if "=" not in text:
        raise ValueError(f"axis must look like NAME=START:STOP:COUNT or NAME=V1,V2,…; got {text!r}")
    name, spec = (s.strip() for s in text.split("=", 1))
    if name not in PARAMETERS:
        raise ValueError(f"unknown parameter {name!r}; accepted: {', '.join(PARAMETERS)}")
    try:
        if ":" in spec:
            parts = spec.split(":")
            log = len(parts) == 4 and parts[3] == "log"
            if len(parts) not in (3, 4) or (len(parts) == 4 and not log):
                raise ValueError("expected START:STOP:COUNT or START:STOP:COUNT:log")
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1:
                raise ValueError(f"COUNT must be ≥ 1; got {count}")
            if log:
                if start <= 0 or stop <= 0:
                    raise ValueError("log spacing needs START, STOP > 0")
                values = np.geomspace(start, stop, count)
            else:
                values = np.linspace(start, stop, count)
        else:
            values = np.array([float(v) for v in spec.split(",")])
    except ValueError as exc:
        raise ValueError(f"bad axis {text!r}: {exc}") from None
    if not np.all(np.isfinite(values)):
        raise ValueError(f"axis {name} values must be finite; got {spec!r}")
    return name, values


def parse_region(text):
    """``XMIN:XMAX:YMIN:YMAX:N`` -> (x range, y range, n)."""
    try:
        xmin, xmax, ymin, ymax, n = text.split(":")
        return (float(xmin), float(xmax)), (float(ymin), float(ymax)), int(n)
    except ValueError:
        raise ValueError(f"region must be XMIN:XMAX:YMIN:YMAX:N (m, m, m, m, points); got {text!r}") from None


def unused_parameters(kind):
    """Parameters that do not apply to sensor ``kind`` (refused as axes or ``--set``)."""
    if kind == "E":
        return MAGNETIC_ONLY
    return ELECTRIC_ONLY + {"B": ("noise_g", "baseline"), "G": ("noise",), "BG": ()}[kind]


def default_noise(kind):
    """The noise parameters of sensor ``kind`` at its defaults (:class:`core.Sensor`)."""
    nb, ng = core.MAGNETIC_NOISE
    return {"E": {"noise": core.DEFAULT_NOISE}, "B": {"noise": nb}, "G": {"noise_g": ng},
            "BG": {"noise": nb, "noise_g": ng}}[kind]


def sensor_of(params, settings):
    """The :class:`core.Sensor` of one cell: ``settings["sensor"]`` (a kind name, default
    ``"E"``) with the cell's noise, medium and baseline."""
    kind = settings.get("sensor") or "E"
    if kind not in SENSORS:
        raise ValueError(f"sensor must be one of {list(SENSORS)}; got {kind!r}")
    noise, noise_g = params.get("noise"), params.get("noise_g")
    if kind == "E":
        sea = None
        if settings.get("sea_depth") is not None:  # the layered sea of core.model.sea (z is depth)
            sea = core.Sea(settings["sea_depth"], settings.get("seabed_sigma", 0.0))
        return core.Sensor("E", noise, params["sigma"], sea, settings.get("model", "exact"))
    if settings.get("sea_depth") is not None or settings.get("model", "exact") != "exact":
        raise ValueError(f"sensor {kind!r} is magnetic: --sea-depth and --model are electric options")
    nb, ng = core.MAGNETIC_NOISE
    value = {"B": noise, "G": noise_g, "BG": (nb if noise is None else noise,
                                              ng if noise_g is None else noise_g)}[kind]
    baseline = params.get("baseline") or None
    return core.Sensor(kind, value, baseline=baseline if kind != "B" else None)


def scenario(params, settings=None):
    """Target state and Γ options from a full parameter dict (see :data:`PARAMETERS`): the
    state (7,) ``[x, y, z, vx, vy, Ph, Pv]`` of the electric kind, (8,) ``[…, mx, my, mz]`` of
    the magnetic kinds (``settings["sensor"]``), and ``{"T": …, "sensor": core.Sensor}``."""
    settings = {} if settings is None else settings
    sensor = sensor_of(params, settings)
    vx, vy = core.velocity_from_heading(params["speed"], params["heading"])
    if sensor.magnetic:
        moments = [params["mx"], params["my"], params["mz"]]
    else:
        ph = params["Ph"] if params.get("ratio") is None else params["ratio"] * params["Pv"]
        moments = [ph, params["Pv"]]
    state = np.array([params["x"], params["y"], params["z"], vx, vy, *moments])
    return state, {"T": params["T"], "sensor": sensor}


def evaluate(params, settings):
    """The measure for one cell; raises ValueError on invalid parameters (e.g. d ≤ 0)."""
    state, opts = scenario(params, settings)
    stations = core.station_layout(settings["layout"], settings["stations"], d=params["d"],
                                   h=params["h"])
    measure, steps = settings["measure"], settings["steps"]
    if SWEEP_MEASURES[measure][2]:
        (xr, yr, n) = settings["region"]
        region = core.Plane("xy", xr, yr, float(params["z"]), n)
        return core.layout_criterion(stations, region, velocity=state[3:5], moments=state[5:],
                                     criterion=measure, threshold=settings["threshold"],
                                     steps=steps, **opts).value
    dist = np.min(np.linalg.norm(stations - state[:3], axis=1))
    if dist < 1e-6:
        return math.nan  # target on a station: the field is singular there
    if measure == "log10_det":
        return float(core.log10_abs_det_gamma(state, stations, **opts))
    if measure == "log10_eta":
        return float(core.observability_index(state, stations, steps=steps, **opts))
    if measure == "rank":
        return float(core.observable_rank(state, stations, steps=steps, **opts))
    if measure == "d_optimal":
        return float(core.fisher_measures(state, stations, steps=steps, **opts).d_optimal)
    e = core.horizontal_error_ellipse(state, stations, steps=steps, **opts)
    field = {"crlb_position": "position", "crlb_semi_major": "semi_major",
             "crlb_semi_minor": "semi_minor", "crlb_depth": "sigma_z",
             "crlb_speed": "sigma_speed"}[measure]
    return float(getattr(e, field))


def _row(base, xname, xvals, yname, yval, settings):
    """One row of the grid (all x at one y): list of floats."""
    out = []
    for xv in xvals:
        params = dict(base, **{xname: float(xv), yname: float(yval)})
        out.append(evaluate(params, settings))
    return out


def _init_worker():
    """One numba thread per worker process: the pool supplies the parallelism."""
    numba.set_num_threads(1)


def run(xaxis, yaxis, settings, base, workers=2, progress=True, client=None):
    """Evaluate the grid; returns values (len(y), len(x)). Rows run in ``workers`` processes,
    or, given a ``distributed.Client`` as ``client``, as tasks on its cluster."""
    (xname, xvals), (yname, yvals) = xaxis, yaxis
    values = np.full((yvals.size, xvals.size), np.nan)
    bar = tqdm(total=yvals.size * xvals.size, unit="cell", disable=not progress,
               desc=f"{settings['measure']} over {xname}×{yname}")
    if client is not None:
        calls = [(base, xname, xvals, yname, yv, settings) for yv in yvals]
        for i, row in dask_backend.map_unordered(dask_backend.check_client(client), _row, calls):
            values[i] = row
            bar.update(xvals.size)
    elif workers == 1:
        for i, yv in enumerate(yvals):
            values[i] = _row(base, xname, xvals, yname, yv, settings)
            bar.update(xvals.size)
    else:
        # spawn, not fork: forking a process whose numba thread pool is running is unsafe.
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                 initializer=_init_worker) as pool:
            futures = {pool.submit(_row, base, xname, xvals, yname, yv, settings): i
                       for i, yv in enumerate(yvals)}
            for fut in as_completed(futures):
                values[futures[fut]] = fut.result()
                bar.update(xvals.size)
    bar.close()
    return values


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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    label, unit, _ = SWEEP_MEASURES[measure]
    fig, ax = plt.subplots(figsize=(7, 5), dpi=110)
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
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


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
    try:
        values = run(xaxis, yaxis, settings, base, workers=args.workers,
                     progress=not args.no_progress, client=client)
    finally:
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
