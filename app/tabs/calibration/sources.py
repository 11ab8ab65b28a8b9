"""The Calibration tab's data sources: the readings each gives (a designed manoeuvre or seed 004's
simulation, sailed by a simulated ship; seed 004's Table 1; an uploaded CSV)."""

from __future__ import annotations

import numpy as np

from core import calibration as cal


def parse_headings(text):
    """Headings (deg) from comma- or space-separated text, each within ±360°, returned wrapped
    to (−180°, 180°] (360° is north, as 0°); ValueError saying what is wrong.

    Wrapped, as core's random attitudes are: core takes angles up to 2π rad in magnitude, and
    a heading of ±360° plus the simulated angle error would exceed it ("radians?") although the
    tab accepted it."""
    parts = [p for p in str(text).replace(",", " ").split() if p]
    try:
        vals = [float(p.replace("−", "-")) for p in parts]
    except ValueError:
        raise ValueError(f"Headings must be numbers in degrees separated by commas; got {str(text)[:60]!r}") from None
    if not vals or len(vals) > 72 or not all(np.isfinite(vals)) or max(map(abs, vals)) > 360:
        raise ValueError("Headings must be 1 to 72 numbers in degrees, each within ±360")
    return [180.0 - (180.0 - v) % 360.0 for v in vals]


def readings(v, be, conv, upload=None):
    """The readings of the data source ``v["cal_source"]`` (``v``: the cal_ values; ``be``: the
    geomagnetic field (3,), nT; ``conv``: the attitude convention; ``upload``: the uploaded CSV
    bytes): (B (N, 3) nT, attitudes (N, 3) rad, the simulation's true (K, Bp) or None, the
    attitudes as designed or None). ValueError saying what is wrong."""
    sim = cal.SEED004_SIMULATION
    truth = None
    nominal = None  # the attitudes as designed (simulated cases): observability is theirs
    rng = np.random.default_rng(int(v["cal_seed"]))
    src = v["cal_source"]
    if src in ("Designed manoeuvre", "Seed 004 simulation"):
        truth = (np.array(sim["K"]), np.array(sim["Bp"]))
        n = int(v["cal_n_attitudes"])
        if src == "Designed manoeuvre":
            att = cal.heading_manoeuvre(parse_headings(v["cal_headings"]), roll_deg=v["cal_roll_deg"],
                                        pitch_deg=v["cal_pitch_deg"], n_attitudes=n)
        else:
            att = cal.random_attitudes(n, rng)
        # the simulated ship is recorded in the chosen convention
        B, rec = cal.simulate_ship_data(*truth, att, be, rng, noise_nt=v["cal_noise_nt"],
                                        angle_noise_deg=v["cal_angle_noise_deg"], convention=conv)
        nominal = att
    elif src == "Seed 004 Table 1":
        B, rec = cal.seed004_table1()
    else:
        if not upload:
            raise ValueError("Upload a CSV file (columns B1, B2, B3 in nT, psi, theta, phi in rad)")
        B, rec = cal.parse_attitude_csv(upload)
    return B, rec, truth, nominal
