"""Input checks at the public boundary of :mod:`core`.

Every public function converts and checks here, then hands plain float64 arrays to kernels
that assume valid input. Messages name the parameter, the offending value and what is accepted.
"""

from __future__ import annotations

import numpy as np

from ..kernels.electric import N_STATES, ON_STATION  # the kernels' bound and size, checked here

#: Order of the state vector ``X = [x, y, z, vx, vy, Ph, Pv]`` (N_STATES entries).
STATE_NAMES = ("x", "y", "z", "vx", "vy", "Ph", "Pv")


def finite(name, arr):
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise ValueError(f"{name} must be finite; got a value {bad!r} (NaN and inf are not accepted)")


def as_array(name, value):
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array: {exc}") from None


def states(value):
    """Return electric states as a contiguous (P, 7) float64 array and the leading shape."""
    arr = as_array("states", value)
    if arr.ndim < 1 or arr.shape[-1] != N_STATES:
        raise ValueError(
            f"states must have shape (..., {N_STATES}) = [x, y, z, vx, vy, Ph, Pv]; got shape "
            f"{arr.shape}"
        )
    finite("states", arr)
    flat = np.ascontiguousarray(arr.reshape(-1, N_STATES))
    if np.any((flat[:, 3] == 0.0) & (flat[:, 4] == 0.0)):
        raise ValueError(
            "target speed must be > 0: the horizontal dipole points along the heading "
            "θ = atan2(vy, vx), which is undefined at vx = vy = 0"
        )
    return flat, arr.shape[:-1]


def stations(value):
    """Return stations as a contiguous (S, 3) float64 array, S ≥ 1."""
    arr = as_array("stations", value)
    if arr.shape == (3,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"stations must have shape (S, 3) station positions in m; got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError("stations must hold at least one station; got an empty list")
    finite("stations", arr)
    return np.ascontiguousarray(arr)


def states_and_stations(states_value, stations_value):
    """Both of the above: (P, 7) states, (S, 3) stations, leading shape."""
    flat, lead = states(states_value)
    return flat, stations(stations_value), lead


def positive(name, value, unit, *, zero=False):
    """A finite float > 0 (≥ 0 with ``zero``), or ValueError."""
    bound = "≥ 0" if zero else "> 0"
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number {bound} ({unit}); got {value!r}") from None
    if not np.isfinite(v) or v < 0.0 or (v == 0.0 and not zero):
        raise ValueError(f"{name} must be a finite number {bound} ({unit}); got {value!r}")
    return v


def model_code(model, models):
    """Index of ``model`` in ``models`` (the kernels' model code)."""
    if not isinstance(model, str) or model not in models:
        raise ValueError(f"model must be one of {list(models)}; got {model!r}")
    return models.index(model)


def integer(name, value, low, high=None, what=""):
    """An integer in [low, high] (high None: no upper limit), or ValueError naming the range."""
    if (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low
            or (high is not None and value > high)):
        rng = f"≥ {low}" if high is None else f"from {low} to {high:,}".replace(",", " ")
        raise ValueError(f"{name} must be an integer {rng}{what}; got {value!r}")
    return int(value)


def steps(value, minimum):
    """Number of instants N: an int ≥ ``minimum``."""
    return integer("steps", value, minimum, what=" (number of instants)")


def free_columns(known, names=STATE_NAMES):
    """Indices of the unknown states among ``names`` (the electric state's by default), given
    the names of the known ones."""
    known = () if known is None else ((known,) if isinstance(known, str) else tuple(known))
    for name in known:
        if name not in names:
            raise ValueError(f"known states must be names from {names}; got {name!r}")
    free = [j for j, name in enumerate(names) if name not in known]
    if not free:
        raise ValueError(f"at least one state must be unknown; got all {len(names)} as known")
    return np.array(free, dtype=np.int64)


def station_distances(states, stations):
    """Distance (m) from every target (P, 7) to every station (S, 3): (P, S)."""
    return np.linalg.norm(states[:, None, :3] - stations[None, :, :], axis=-1)


def point_text(v):
    """A position as plain numbers, "(0, 0, 100)": ``tuple()`` of a numpy row prints
    ``np.float64(0.0)`` for each coordinate (numpy ≥ 2), which a reader of an error should not see."""
    return "(" + ", ".join(f"{float(c):g}" for c in np.ravel(v)) + ")"


def no_target_on_station(states, stations):
    d = station_distances(states, stations)
    if np.any(d < ON_STATION):
        p, s = np.argwhere(d < ON_STATION)[0]
        raise ValueError(
            f"target position {point_text(states[p, :3])} m coincides with station {s} at "
            f"{point_text(stations[s])} m: the dipole field is singular at D = 0 (closer than {ON_STATION} m counts); "
            "move the target or mask such points (core.observability.maps does)"
        )
