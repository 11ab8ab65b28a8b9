"""Manoeuvres (lists of attitudes) to calibrate on, and simulated readings along them as in seed
004's simulation.
"""

from __future__ import annotations

import numpy as np

from .model import ship_field
from ..model.validation import integer, positive
from .validation import _array, _attitudes


def _angles_deg(name, value):
    arr = _array(name, value, "degrees")
    return np.atleast_1d(arr)


def level_headings(headings_deg=(0.0, 90.0, 180.0, 270.0)):
    """The classic four-heading manoeuvre: level (roll = pitch = 0) on each heading.

    Parameters
    ----------
    headings_deg : sequence of float
        Headings (deg, clockwise from north); default N, E, S, W.

    Returns
    -------
    ndarray, shape (H, 3)
        Attitudes [ψ, 0, 0] (rad).
    """
    h = _angles_deg("headings_deg", headings_deg)
    if h.ndim != 1 or h.size < 1:
        raise ValueError("headings_deg must be a non-empty sequence of headings in degrees")
    return np.stack([np.deg2rad(h), np.zeros_like(h), np.zeros_like(h)], axis=-1)


def heading_manoeuvre(headings_deg=(0.0, 90.0, 180.0, 270.0), *, roll_deg=10.0, pitch_deg=5.0,
                      n_attitudes=12):
    """Headings sailed in turn while the ship rolls and pitches.

    Attitude n (n = 0…N−1) is on heading ``headings_deg[n mod H]`` with roll
    ``roll_deg · cos(2π n / N)`` and pitch ``pitch_deg · sin(2π n / N)``: roll and pitch trace one
    ellipse of the given amplitudes over the manoeuvre, so they vary between attitudes (a
    constant heel, like level headings, leaves K's third column and Bp confounded).

    Parameters
    ----------
    headings_deg : sequence of float
        Headings (deg).
    roll_deg, pitch_deg : float
        Amplitudes (deg), |·| ≤ 90.
    n_attitudes : int
        N ≥ 1.

    Returns
    -------
    ndarray, shape (N, 3)
        Attitudes [ψ, θ, φ] (rad).

    Examples
    --------
    >>> import core
    >>> core.heading_manoeuvre(n_attitudes=12).shape
    (12, 3)
    """
    h = _angles_deg("headings_deg", headings_deg)
    if h.ndim != 1 or h.size < 1:
        raise ValueError("headings_deg must be a non-empty sequence of headings in degrees")
    for name, v in (("roll_deg", roll_deg), ("pitch_deg", pitch_deg)):
        a = _array(name, v, "degrees")
        if a.shape != () or abs(float(a)) > 90:
            raise ValueError(f"{name} must be one amplitude in degrees with |{name}| ≤ 90; got {v!r}")
    n = np.arange(integer("n_attitudes", n_attitudes, 1))
    t = 2.0 * np.pi * n / n_attitudes
    return np.stack([np.deg2rad(h[n % h.size]), np.deg2rad(float(roll_deg)) * np.cos(t),
                     np.deg2rad(float(pitch_deg)) * np.sin(t)], axis=-1)


def random_attitudes(n_attitudes, rng, *, heading_deg=(0.0, 360.0), roll_deg=(-20.0, 20.0),
                     pitch_deg=(-15.0, 15.0), size=()):
    """Attitudes drawn uniformly in ranges, as in seed 004's simulation (defaults are its ranges).

    Parameters
    ----------
    n_attitudes : int
        N ≥ 1.
    rng : numpy.random.Generator
    heading_deg, roll_deg, pitch_deg : (float, float)
        Ranges (deg).
    size : tuple of int
        Leading shape (independent manoeuvres).

    Returns
    -------
    ndarray, shape size + (N, 3)
        ψ, θ, φ (rad); headings above 180° are returned as ψ − 360° so that |ψ| ≤ π.
    """
    integer("n_attitudes", n_attitudes, 1)
    cols = []
    for name, r in (("heading_deg", heading_deg), ("roll_deg", roll_deg), ("pitch_deg", pitch_deg)):
        lo, hi = _array(name, r, "(low, high) degrees")
        if not lo <= hi or max(abs(lo), abs(hi)) > 360:
            raise ValueError(f"{name} must be (low, high) degrees with low ≤ high, |·| ≤ 360; got {r!r}")
        cols.append(np.deg2rad(rng.uniform(lo, hi, size=tuple(size) + (n_attitudes,))))
    cols[0] = np.angle(np.exp(1j * cols[0]))  # wrap to (−π, π]
    return np.stack(cols, axis=-1)


def simulate_ship_data(K, Bp, attitudes, be, rng, *, noise_nt=0.0, angle_noise_deg=0.0,
                       distribution="uniform", convention="seed004"):
    """Readings at the true attitudes plus errors, and the attitudes as recorded (with errors).

    Parameters
    ----------
    K, Bp, attitudes, be, convention
        As for :func:`ship_field`; attitudes (..., N, 3) are the true ones.
    rng : numpy.random.Generator
    noise_nt : float
        Error size on each reading (nT), ≥ 0.
    angle_noise_deg : float
        Error size on each recorded angle (deg), ≥ 0.
    distribution : {"uniform", "gaussian"}
        ``"uniform"``: errors uniform in ±size (seed 004: "random errors of at most 100 nT /
        0.05°"; a bound, so uniform; standard deviation size/√3). ``"gaussian"``: standard
        deviation = size.

    Returns
    -------
    B : ndarray, shape (..., N, 3)
        Readings (nT).
    recorded : ndarray, shape (..., N, 3)
        Recorded attitudes (rad).
    """
    att = _attitudes(attitudes)
    sb = positive("noise_nt", noise_nt, "nT", zero=True)
    sa = np.deg2rad(positive("angle_noise_deg", angle_noise_deg, "deg", zero=True))
    if distribution == "uniform":
        draw = lambda s: rng.uniform(-s, s, size=att.shape)
    elif distribution == "gaussian":
        draw = lambda s: rng.normal(0.0, s, size=att.shape) if s > 0 else np.zeros(att.shape)
    else:
        raise ValueError(f"distribution must be 'uniform' or 'gaussian'; got {distribution!r}")
    B = ship_field(K, Bp, att, be, convention=convention) + draw(sb)
    return B, att + draw(sa)

