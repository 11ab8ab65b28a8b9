"""The two-parameter sweep: any two scenario parameters over a grid, one measure per cell.

The engine of ``python -m core.sweep`` (its command line, CSV and heatmap are
:mod:`core.cli.sweep`, which describes the options). A cell is a full parameter dict
(:data:`PARAMETERS`) and settings (measure, layout, sensor, medium, steps, region); :func:`evaluate`
computes one cell, :func:`row` one row of the grid, :func:`run` the grid: rows in worker
processes or, given a ``distributed.Client``, as tasks on its cluster
(:func:`core.dask_backend.run_calls`, docs/dask.md). The values are the same bit for
bit either way (each cell is computed by the same code).
"""

from __future__ import annotations

import math

import numpy as np

import core

from .. import dask_backend

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


def row(base, xname, xvals, yname, yval, settings):
    """One row of the grid (all x at one y): list of floats."""
    out = []
    for xv in xvals:
        params = dict(base, **{xname: float(xv), yname: float(yval)})
        out.append(evaluate(params, settings))
    return out


def run(xaxis, yaxis, settings, base, workers=2, progress=None, client=None):
    """Evaluate the grid; returns values (len(y), len(x)). Rows run in ``workers`` processes,
    or, given a ``distributed.Client`` as ``client``, as tasks on its cluster
    (:func:`core.dask_backend.run_calls`). ``progress``: a callable given the number of cells
    each finished row adds (the CLI's progress bar), or None."""
    (xname, xvals), (yname, yvals) = xaxis, yaxis
    values = np.full((yvals.size, xvals.size), np.nan)
    calls = [(base, xname, xvals, yname, yv, settings) for yv in yvals]
    for i, cells in dask_backend.run_calls(row, calls, workers=workers, client=client):
        values[i] = cells
        if callable(progress):
            progress(xvals.size)
    return values
