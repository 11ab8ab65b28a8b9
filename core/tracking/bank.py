"""Seed 001's filter bank: K strength levels × N_F bearings of (PU)EKFs, ML selection (§2).

Without a prior, a tracker does not know where the target is. Seed 001 starts a bank of
filters, one per hypothesis, and reports at every step the one with the largest accumulated
log-likelihood of its innovations. Our reading of its eqs. (11)–(15), where the text is lost
(docs/tracking.md, *The filter bank*): strength levels p_i, bearings ψ_j of the start from the
array centre (our frame, :data:`SEED_BEARINGS` for seed 001's), the start range solving
``‖h(x_ij(r))‖ = ‖y_0‖`` on the core's own model by bisection (no empirical factor), an inbound
heading, and the covariance of eq. (15). Any sensor kind: the hypotheses' moments come from
:meth:`core.Sensor.bank_moments`. Filter n = N_F·(i − 1) + j (1-based), strength-major, as seed
001's: with the defaults filter 7 is (100 A·m, ψ₃).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.measurement import SensorModel
from ..model.sensors import sensor_model
from ..model.validation import integer
from .filters import run_filters

__all__ = ["BANK_BEARINGS", "BANK_STRENGTHS", "SEED_BEARINGS", "BankResult", "bank_hypotheses",
           "run_bank", "start_range"]

#: Seed 001's strength levels (A·m).
BANK_STRENGTHS = (50.0, 100.0, 200.0)
#: Seed 001's bearings (rad) in its own z-up frame (x, y, z_up).
SEED_BEARINGS = (np.pi / 4, 3 * np.pi / 4, 5 * np.pi / 4, 7 * np.pi / 4)
#: The same bearings in our right-handed frame (x, −y_seed, depth): ψ → −ψ (mod 2π). Seed
#: bearing j is our bearing j, so filter numbers are seed 001's.
BANK_BEARINGS = tuple(float((-b) % (2 * np.pi)) for b in SEED_BEARINGS)


def start_range(y0, sensors, strengths, bearings, *, depth, speed=2.0,
                centre=None, r_min=1.0, r_max=5000.0, iterations=48):
    """Start range r (m) of every hypothesis from the measured field magnitude.

    Parameters
    ----------
    y0 : array_like, shape (R, m) or (R, n, m)
        First measurement(s) of R runs (V/m); with n of them, ‖y‖² is averaged over them.
    sensors : core.SensorModel
    strengths : sequence of float
        p_i (A·m), > 0.
    bearings : sequence of float
        ψ_j (rad) in our frame.
    depth : float
        Source depth of every hypothesis (m).
    speed : float
        Prior speed (m/s), > 0.
    centre : array_like, shape (2,), optional
        Array centre (m); default the mean of the stations' x, y.
    r_min, r_max : float
        Search interval (m); a field too strong (weak) for the interval gives r_min (r_max).
    iterations : int
        Bisection steps in log r.

    Returns
    -------
    ndarray, shape (R, K·N_F)
        Ranges, strength-major.
    """
    y0 = np.asarray(y0, dtype=float)
    if y0.ndim == 2:
        y0 = y0[:, None, :]
    if y0.ndim != 3 or y0.shape[2] != sensors.n_meas or y0.shape[1] == 0:
        raise ValueError(f"y0 must have shape (R, {sensors.n_meas}) or (R, n, {sensors.n_meas}); got {y0.shape}")
    p = np.repeat(np.asarray(strengths, float), len(bearings))  # (H,)
    psi = np.tile(np.asarray(bearings, float), len(strengths))  # (H,)
    c = np.mean(sensors.stations[:, :2], axis=0) if centre is None else np.asarray(centre, float)
    # ‖h‖² estimate: E‖y‖² = ‖h‖² + Σ σ²; keep it positive (a field below the noise → r_max).
    var = np.sum(np.asarray(sensors.noise_vector, float) ** 2)
    target = np.maximum((y0**2).sum(axis=2).mean(axis=1) - var, 1e-6 * var / sensors.n_meas)
    n_runs, n_h = y0.shape[0], p.size
    lo = np.full((n_runs, n_h), np.log(r_min))
    hi = np.full((n_runs, n_h), np.log(r_max))

    def norm2(logr):
        st = hypothesis_states(np.exp(logr), p, psi, c, depth, speed, sensors.sensor)  # (R, H, n)
        return (sensors.h(st) ** 2).sum(axis=-1)

    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        weaker = norm2(mid) < target[:, None]  # field at mid too weak: the target is nearer
        hi = np.where(weaker, mid, hi)
        lo = np.where(weaker, lo, mid)
    return np.exp(0.5 * (lo + hi))


def hypothesis_states(r, p, psi, centre, depth, speed, sensor=None):
    """States (…, H, n) of hypotheses at range r (…, H), strength p (H,), bearing ψ (H,):
    position centre + r (cos ψ, sin ψ) at ``depth``, inbound heading ψ + π at ``speed``, the
    moments of :meth:`core.Sensor.bank_moments` (electric when ``sensor`` is None)."""
    sensor = sensor_model(sensor)
    r = np.asarray(r, float)
    out = np.empty(r.shape + (sensor.n_states,))
    out[..., 0] = centre[0] + r * np.cos(psi)
    out[..., 1] = centre[1] + r * np.sin(psi)
    out[..., 2] = depth
    out[..., 3] = -speed * np.cos(psi)
    out[..., 4] = -speed * np.sin(psi)
    out[..., 5:] = sensor.bank_moments(np.broadcast_to(p, r.shape), 1.0, 1.0)[0]
    return out


def bank_hypotheses(y0, sensors, *, depth, strengths=BANK_STRENGTHS, bearings=BANK_BEARINGS,
                    speed=2.0, speed_std=2.0, position_frac=0.5, depth_std=1.0,
                    strength_frac=0.5, pv_std=10.0, centre=None):
    """Initial means and covariances of the bank (seed 001 eqs. (11)–(15)).

    Parameters
    ----------
    y0 : array_like, shape (R, m) or (R, n, m)
        First measurement(s) of each of R runs (V/m), see :func:`start_range`.
    sensors : core.SensorModel
    depth : float
        Hypothesised source depth (m) (ξ_z = ``depth_std`` about it).
    strengths, bearings : sequence of float
        Strength levels (A·m) and bearings (rad, our frame).
    speed, speed_std : float
        Prior speed (m/s) and its σ per velocity axis (m/s).
    position_frac : float
        Position σ in x and y as a fraction of the start range.
    depth_std : float
        ξ_z (m).
    strength_frac : float
        ξ_p as a fraction of the strength level.
    pv_std : float
        σ of Pv (A·m).
    centre : array_like, shape (2,), optional
        Array centre (m).

    Returns
    -------
    x0 : ndarray, shape (R, H, n)
    P0 : ndarray, shape (R, H, n, n)
    ranges : ndarray, shape (R, H)
        H = K · N_F, strength-major (filter n = N_F (i − 1) + j).
    """
    for name, v in (("speed", speed), ("speed_std", speed_std), ("position_frac", position_frac),
                    ("depth_std", depth_std), ("strength_frac", strength_frac), ("pv_std", pv_std)):
        if not np.isfinite(float(v)) or float(v) <= 0:
            raise ValueError(f"{name} must be a finite number > 0; got {v!r}")
    strengths = np.asarray(strengths, float)
    bearings = np.asarray(bearings, float)
    if strengths.ndim != 1 or strengths.size == 0 or np.any(~np.isfinite(strengths)) or np.any(strengths <= 0):
        raise ValueError(f"strengths must be a non-empty list of moments > 0 (A·m); got {strengths!r}")
    if bearings.ndim != 1 or bearings.size == 0 or np.any(~np.isfinite(bearings)):
        raise ValueError(f"bearings must be a non-empty list of finite angles (rad); got {bearings!r}")
    c = np.mean(sensors.stations[:, :2], axis=0) if centre is None else np.asarray(centre, float)
    ranges = start_range(y0, sensors, strengths, bearings, depth=depth, speed=speed,
                         centre=c)
    p = np.repeat(strengths, bearings.size)
    psi = np.tile(bearings, strengths.size)
    x0 = hypothesis_states(ranges, p, psi, c, depth, speed, sensors.sensor)
    n = sensors.n_states
    std = np.empty(ranges.shape + (n,))
    std[..., 0] = std[..., 1] = position_frac * ranges
    std[..., 2] = depth_std
    std[..., 3] = std[..., 4] = speed_std
    std[..., 5:] = sensors.sensor.bank_moments(np.broadcast_to(p, ranges.shape), strength_frac,
                                               pv_std)[1]
    P0 = np.zeros(ranges.shape + (n, n))
    idx = np.arange(n)
    P0[..., idx, idx] = std**2
    return x0, P0, ranges


@dataclass(frozen=True)
class BankResult:
    """Output of :func:`run_bank` for R runs of an H-filter bank over K steps.

    Attributes
    ----------
    x : ndarray, shape (R, K, n)
        The reported track: at each step the estimate of the filter with the largest
        accumulated log-likelihood (seed 001 eq. (17)).
    selected : ndarray of int, shape (R, K)
        Index (0-based, strength-major) of the reported filter at each step.
    loglik : ndarray, shape (R, H, K)
        Accumulated log-likelihood of every filter, normalised by the bank's maximum at each
        step (seed 001 step 5: the best is 0).
    nees : ndarray, shape (R, K), or None
        NEES of the reported filter.
    position_var : ndarray, shape (R, K)
        Trace of the reported filter's position covariance (m²).
    x_all : ndarray, shape (R, H, K, n)
        Every filter's estimates.
    x0 : ndarray, shape (R, H, n)
        The hypotheses.
    ranges : ndarray, shape (R, H)
        Start ranges from the field magnitude (m).
    """

    x: np.ndarray
    selected: np.ndarray
    loglik: np.ndarray
    nees: np.ndarray | None
    position_var: np.ndarray
    x_all: np.ndarray
    x0: np.ndarray
    ranges: np.ndarray


def run_bank(ys, sensors, F, Q, *, depth, n_pu=1, init_steps=10, truth=None, progress=None,
             **hypotheses):
    """Run the filter bank on R runs' measurements and select by maximum likelihood.

    Parameters
    ----------
    ys : array_like, shape (R, K, m)
        Measurements (V/m).
    sensors : core.SensorModel
    F, Q : ndarray, shape (n, n)
        Filter model, :func:`core.dwna_model`.
    depth : float
        Hypothesised source depth (m).
    n_pu : int
        Progressive sub-updates of every filter (1 = EKF).
    init_steps : int
        Up to how many first measurements (n ≥ 1) set the start ranges by their mean ‖y‖²
        (n = 1 is seed 001's single magnitude; more averages the noise down where the start is
        far and the field near the noise, e.g. seed 001's trial start at ~285 m). A track shorter
        than n steps uses all of its K steps: min(n, K).
    truth : array_like, shape (R, K, n), optional
        True states, for the NEES.
    progress : callable, optional
        Called with 1 after every step.
    **hypotheses
        Passed to :func:`bank_hypotheses` (strengths, bearings, speed, …).

    Returns
    -------
    BankResult
    """
    if not isinstance(sensors, SensorModel):
        raise ValueError(f"sensors must be a core.SensorModel; got {type(sensors).__name__}")
    ys = np.asarray(ys, dtype=float)
    if ys.ndim != 3 or ys.shape[2] != sensors.n_meas:
        raise ValueError(f"ys must have shape (R, K, {sensors.n_meas}); got {ys.shape}")
    n_runs, k_steps, m = ys.shape
    integer("init_steps", init_steps, 1)
    # a short track (e.g. 5 s at T = 1 s: 6 steps) starts from all of its steps: the default 10
    # was refused for every track shorter than 10 steps, which the Track tab accepts
    x0, P0, ranges = bank_hypotheses(ys[:, :min(int(init_steps), k_steps)], sensors, depth=depth,
                                     **hypotheses)
    n_h = x0.shape[1]
    # (R, H, ...) -> (R·H, ...): every filter of every run in one stack
    flat_truth = None if truth is None else np.repeat(np.asarray(truth, float), n_h, axis=0)
    n = sensors.n_states
    run = run_filters(x0.reshape(-1, n), P0.reshape(-1, n, n), np.repeat(ys, n_h, axis=0),
                      sensors, F, Q, n_pu=n_pu, truth=flat_truth, progress=progress)
    ll = run.loglik.reshape(n_runs, n_h, k_steps)
    selected = np.argmax(ll, axis=1)  # (R, K); a dead filter has −inf
    x_all = run.x.reshape(n_runs, n_h, k_steps, n)
    r_i = np.arange(n_runs)[:, None]
    k_i = np.arange(k_steps)[None, :]
    x = x_all[r_i, selected, k_i]  # (R, K, n)
    nees = None if run.nees is None else run.nees.reshape(n_runs, n_h, k_steps)[r_i, selected, k_i]
    pos_var = run.position_var.reshape(n_runs, n_h, k_steps)[r_i, selected, k_i]
    with np.errstate(invalid="ignore"):
        ll_norm = ll - ll.max(axis=1, keepdims=True)
    return BankResult(x=x, selected=selected, loglik=ll_norm, nees=nees, position_var=pos_var,
                      x_all=x_all, x0=x0, ranges=ranges)
