"""Monte-Carlo tracking on seed 001's cases: TRMSE against the PCRLB.

:func:`monte_carlo` runs a filter (EKF, PUEKF or the bank) over many noisy replays of a case
and returns the TRMSE of its position against the PCRLB; ``python -m core.track``
(:mod:`core.cli.track`) writes the result to files, the dashboard's Track tab plots it.

Cases: :mod:`core.tracking.cases` (seed 001's two, any sensor kind); this module runs them.

Truth: the nominal straight track, or DWNA tracks sampled with the filter's own Q
(``truth_noise``). The EKF and PUEKF start from a mean drawn from N(truth₀, P₀) (PCRLB prior
J₀ = P₀⁻¹); the bank from its hypotheses, its PCRLB knowing only what every hypothesis assumes
(docs/tracking.md, *Nominal versus sampled tracks*).

Parallelism: runs are split into chunks; chunk results do not depend on the chunking (run r
draws its noise from ``numpy.random.default_rng([seed, r])``). Chunks run in this process,
in ``workers`` spawned processes (both cores), or on a Dask scheduler (``scheduler=ADDR``).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from .. import dask_backend
from ..model.validation import integer
from .bank import BANK_BEARINGS, BANK_STRENGTHS, SEED_BEARINGS, run_bank
from .cases import CASES, MAGNETIC_MOMENT, TrackCase, case_for_sensor, resolve_case
from .filters import run_filters
from .motion import dwna_model, sample_tracks
from .pcrlb import linearisation_breaks, pcrlb

__all__ = ["CASES", "FILTERS", "MAGNETIC_MOMENT", "NEES_LEVEL", "MonteCarloResult", "TrackCase",
           "case_for_sensor", "monte_carlo", "nees_band"]

#: Filters of :func:`monte_carlo`.
FILTERS = ("ekf", "puekf", "bank")
#: Default progressive sub-updates of "puekf" (seed 001 does not print its N_pu). The bank's
#: default is 1: on seed001-sim (100 runs) the nearest hypothesis won 61 / 45 / 30 / 11 % of the
#: runs with N_pu = 1 / 2 / 3 / 5 — relinearising lets wrong-strength filters converge too, and
#: the likelihood then tells the hypotheses apart less well (docs/tracking.md).
DEFAULT_N_PU = 3


def hypothesis_labels(strengths=BANK_STRENGTHS, seed_bearings=SEED_BEARINGS):
    """Seed 001's filter names: 'F7 p=100 ψ=5π/4' (ψ in seed 001's frame), strength-major."""
    out = []
    for i, p in enumerate(strengths):
        for j, b in enumerate(seed_bearings):
            out.append(f"F{i * len(seed_bearings) + j + 1} p={p:g} ψ={round(4 * b / np.pi):d}π/4")
    return out


def nearest_hypothesis(truth0, centre, strengths=BANK_STRENGTHS, bearings=BANK_BEARINGS,
                       strength=None):
    """Index of the hypothesis nearest a true start state (…, n): the strength level nearest
    in log and the bearing nearest the true start bearing from the array centre. ``strength``
    (…): the true strength, default Ph = truth0[..., 5] (a magnetic target's is |m|)."""
    truth0 = np.asarray(truth0, float)
    true_p = truth0[..., 5] if strength is None else np.asarray(strength, float)
    i = np.argmin(np.abs(np.log(np.asarray(strengths))[None] - np.log(true_p[..., None])), axis=-1)
    b = np.arctan2(truth0[..., 1] - centre[1], truth0[..., 0] - centre[0])
    gap = np.abs(np.angle(np.exp(1j * (b[..., None] - np.asarray(bearings)))))
    j = np.argmin(gap, axis=-1)
    return i * len(bearings) + j


def _run_seed(seed, run):
    return np.random.default_rng([int(seed), int(run)])


def _truths_and_x0(case, filter_name, run_ids, seed, truth_noise):
    """True tracks (n, K, n_x) and filter start means (n, n_x) of the given runs.

    Every run's truth starts at the nominal start; an EKF / PUEKF starts from a mean drawn from
    N(truth₀, P₀) (so that P₀ is its honest prior and the PCRLB's J₀ = P₀⁻¹), kept in the water.
    """
    nominal = case.nominal_track()
    n_x = nominal.shape[-1]
    F, Q = dwna_model(case.T, case.sigma_a, case.alpha, n_states=n_x)
    lo, hi = case.sensors().depth_range
    truths = np.empty((len(run_ids), case.steps, n_x))
    x0 = np.broadcast_to(nominal[0], (len(run_ids), n_x)).copy()
    root = np.asarray(case.prior_std, float)
    for n, r in enumerate(run_ids):
        rng = _run_seed(seed, r)
        if filter_name != "bank":
            x0[n] += root * rng.standard_normal(n_x)
            x0[n, 2] = np.clip(x0[n, 2], lo, hi)
        truths[n] = sample_tracks(nominal[0], F, Q, case.steps, rng) if truth_noise else nominal
    return truths, x0


def _measurements(case, sensors, truths, run_ids, seed):
    h = sensors.h(truths)  # (n, K, m)
    for n, r in enumerate(run_ids):
        rng = _run_seed(seed + 1_000_003, r)  # a stream of its own, independent of the truth's
        h[n] += sensors.noise_vector * rng.standard_normal(h[n].shape)
    return h


def _chunk(case, filter_name, run_ids, seed, n_pu, truth_noise, keep_tracks=0, progress=None):
    """Simulate and filter a chunk of runs; returns plain arrays (picklable for workers)."""
    sensors = case.sensors()
    F, Q = dwna_model(case.T, case.sigma_a, case.alpha, n_states=sensors.n_states)
    truths, x0 = _truths_and_x0(case, filter_name, run_ids, seed, truth_noise)
    ys = _measurements(case, sensors, truths, run_ids, seed)
    out = {"run_ids": np.asarray(run_ids)}
    if filter_name == "bank":
        strengths = {} if case.bank_strengths is None else {"strengths": case.bank_strengths}
        res = run_bank(ys, sensors, F, Q, depth=case.bank_depth, n_pu=n_pu, truth=truths,
                       progress=progress, depth_std=case.bank_depth_std, pv_std=case.bank_pv_std,
                       **strengths)
        est, nees, selected = res.x, res.nees, res.selected[:, -1]
        out["selected"] = selected
        out["loglik"] = res.loglik[:keep_tracks]
        out["x_all"] = res.x_all[:keep_tracks, :, :, :3]
    else:
        run = run_filters(x0, case.prior_cov(), ys, sensors, F, Q, n_pu=n_pu, truth=truths,
                          progress=progress)
        est, nees = run.x, run.nees
    out["error"] = np.linalg.norm(est[..., :3] - truths[..., :3], axis=-1)  # (n, K)
    out["nees"] = nees
    out["truth"] = truths[:keep_tracks, :, :3]
    out["estimate"] = est[:keep_tracks, :, :3]
    return out


def _chunks(runs, n):
    edges = np.linspace(0, runs, n + 1).astype(int)
    return [list(range(a, b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]


@dataclass(frozen=True)
class MonteCarloResult:
    """Output of :func:`monte_carlo`; arrays over K steps and R runs.

    Attributes
    ----------
    time_s : ndarray (K,)
    trmse_m, pcrlb_m : ndarray (K,)
        TRMSE (seed 001 eq. (18)) and PCRLB position σ (m).
    error_m : ndarray (R, K)
        Position error of every run's reported estimate (m).
    nees : ndarray (R, K)
    summary : dict
        What :func:`write_outputs` writes to summary.json.
    tracks : dict
        A few runs' true and estimated positions (and, for the bank, every filter's).
    """

    time_s: np.ndarray
    trmse_m: np.ndarray
    pcrlb_m: np.ndarray
    error_m: np.ndarray
    nees: np.ndarray
    summary: dict
    tracks: dict


def monte_carlo(case="seed001-sim", *, filter="bank", runs=100, seed=0, n_pu=None, workers=1,
                scheduler=None, chunks=None, truth_noise=False, keep_tracks=5, progress=None,
                sensor=None):
    """Monte-Carlo runs of a filter on a case: TRMSE against the PCRLB.

    Parameters
    ----------
    case : str or TrackCase
        A key of :data:`CASES` or a custom case.
    filter : {"ekf", "puekf", "bank"}
    runs : int
        Number of Monte-Carlo runs R ≥ 1.
    seed : int
        Seed of every run's noise (run r uses ``default_rng([seed, r])``).
    n_pu : int, optional
        Progressive sub-updates (default 1 for "ekf" and "bank", :data:`DEFAULT_N_PU` for
        "puekf").
    workers : int
        Processes to spread the chunks over (1 = this process).
    scheduler : str or dask.distributed.Client, optional
        A Dask scheduler address (or client): chunks are submitted to it.
    chunks : int, optional
        Number of chunks (default: ``workers``, or 2 × the Dask workers).
    truth_noise : bool
        Sample the true tracks from the DWNA model instead of the straight nominal track.
    keep_tracks : int
        Runs whose tracks are kept in the result (for plots).
    progress : tqdm-like, optional
        A progress bar (``reset(total=)``, ``update(n)``, ``close()``; the command line passes a
        ``tqdm``), advanced per chunk or per step and closed at the end; None: silent.
    sensor : core.Sensor or str, optional
        The measurement model, replacing the case's (a magnetic one needs a case with
        ``moments`` and an 8-entry ``prior_std``; the bank is electric only).

    Returns
    -------
    MonteCarloResult
    """
    case = resolve_case(case)
    if sensor is not None:
        case = dataclasses.replace(case, sensor=sensor)
    case.check()
    if filter not in FILTERS:
        raise ValueError(f"filter must be one of {list(FILTERS)}; got {filter!r}")
    runs, workers, seed = (integer(name, v, lo) for name, v, lo in (
        ("runs", runs, 1), ("workers", workers, 1), ("seed", seed, 0)))
    n_pu = integer("n_pu", (DEFAULT_N_PU if filter == "puekf" else 1) if n_pu is None else n_pu, 1)
    if filter == "ekf" and n_pu != 1:
        raise ValueError("filter 'ekf' has n_pu = 1; use filter 'puekf' for progressive updates")
    sensors = case.sensors()  # fails early (e.g. no layered sea) before any worker starts
    t0 = time.perf_counter()
    if isinstance(scheduler, str):  # an address: a client of our own, closed at the end
        from distributed import Client

        client = Client(scheduler, set_as_default=False)
    else:
        client = scheduler
    bar = progress
    try:
        if client is None and workers == 1:
            if bar is not None:
                bar.reset(total=case.steps)
            results = [_chunk(case, filter, list(range(runs)), seed, n_pu, bool(truth_noise),
                              keep_tracks, progress=None if bar is None else bar.update)]
        else:
            if chunks is None and client is not None:
                chunks = 2 * max(1, len(client.scheduler_info().get("workers", {})))
            calls = [(case, filter, ids, seed, n_pu, bool(truth_noise),
                      keep_tracks if n == 0 else 0)
                     for n, ids in enumerate(_chunks(runs, chunks or workers))]
            if bar is not None:
                bar.reset(total=len(calls))
            results = []
            for _, res in dask_backend.run_calls(_chunk, calls, workers=workers, client=client):
                results.append(res)
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if client is not scheduler:
            client.close()
    results.sort(key=lambda r: r["run_ids"][0])
    elapsed = time.perf_counter() - t0
    return _collect(case, filter, int(n_pu), seed, runs, truth_noise, sensors, results, elapsed,
                    workers if scheduler is None else "dask")


#: Two-sided probability of :func:`nees_band`.
NEES_LEVEL = 0.99


def nees_band(dof, runs, level=NEES_LEVEL):
    """(low, high): the two-sided ``level`` χ² interval of the mean NEES of ``runs`` independent
    runs of a consistent ``dof``-state filter — the mean of ``runs`` χ²(dof) draws, i.e.
    χ²(dof · runs) / runs. The instants of one run are correlated, so only the runs count as
    independent: a wider, conservative band than one counting every instant."""
    from scipy.stats import chi2

    dof, runs = int(dof), int(runs)
    if dof < 1 or runs < 1:
        raise ValueError(f"dof and runs must be ≥ 1; got {dof}, {runs}")
    return tuple(float(chi2.ppf(q, dof * runs) / runs) for q in ((1 - level) / 2, (1 + level) / 2))


def _collect(case, filter_name, n_pu, seed, runs, truth_noise, sensors, results, elapsed, workers):
    error = np.concatenate([r["error"] for r in results])  # (R, K)
    nees = np.concatenate([r["nees"] for r in results])
    run_ids = np.concatenate([r["run_ids"] for r in results])
    truths, _ = _truths_and_x0(case, filter_name, run_ids, seed, truth_noise)
    if filter_name == "bank":
        prior = dict(prior_info=case.bank_prior_info())
    else:
        prior = dict(prior_cov=case.prior_cov())
    bound = pcrlb(truths, sensors, T=case.T, sigma_a=case.sigma_a, alpha=case.alpha,
                  **prior).position_std
    trmse = np.sqrt(np.mean(error**2, axis=0))
    # Divergence is judged against the final bound, and only where that bound predicts a
    # tracker's error: a final PCRLB beyond linearisation_breaks' limit × the range to the
    # nearest station (or infinite) is no yardstick, and judging by it said "diverged 0 %"
    # beside final errors of 2.3 km (5 × a 4.5 km bound). There: "diverged" is None, said so.
    final_range = np.min(np.linalg.norm(truths[:, -1, None, :3] - sensors.stations[None], axis=-1),
                         axis=-1)  # (R,)
    judged = not bool(np.any(linearisation_breaks(np.full(final_range.shape, bound[-1]), final_range)))
    limit = max(5.0 * bound[-1], 10.0) if judged else np.inf
    diverged = error[:, -1] > limit
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(nees)
    nees_mean = float(np.mean(nees[finite])) if finite.any() else None
    band = nees_band(sensors.n_states, runs)
    summary = {
        "case": case.name,
        "description": case.description,
        "filter": filter_name,
        "n_pu": n_pu,
        "runs": int(runs),
        "seed": int(seed),
        "steps": int(case.steps),
        "truth_noise": bool(truth_noise),
        "diverged": float(diverged.mean()) if judged else None,
        "diverged_rule": ("final position error > max(5 × final PCRLB, 10 m)" if judged else
                          f"not judged: the final PCRLB ({bound[-1]:.3g} m) exceeds "
                          f"0.3 × the range to the nearest station ({final_range.min():.3g} m), "
                          "where it does not predict a tracker's error"),
        "final_error_range_m": [float(error[:, -1].min()), float(error[:, -1].max())],
        "nees": nees_mean,
        "nees_dof": int(sensors.n_states),
        "nees_band": list(band),
        "nees_level": NEES_LEVEL,
        # None when no NEES was computed; a plain bool for JSON
        "nees_consistent": None if nees_mean is None else bool(band[0] <= nees_mean <= band[1]),
        "nees_finite_share": float(finite.mean()),
        "trmse_final_m": float(trmse[-1]),
        "trmse_mean_m": float(np.mean(trmse)),
        "pcrlb_final_m": float(bound[-1]),
        "trmse_final_converged_m": float(np.sqrt(np.mean(error[~diverged, -1] ** 2)))
        if judged and (~diverged).any() else None,
        "elapsed_s": round(elapsed, 3),
        "workers": workers,
    }
    tracks = {"truth": results[0]["truth"], "estimate": results[0]["estimate"]}
    if filter_name == "bank":
        levels = BANK_STRENGTHS if case.bank_strengths is None else case.bank_strengths
        labels = hypothesis_labels(levels)
        selected = np.concatenate([r["selected"] for r in results])
        centre = np.mean(sensors.stations[:, :2], axis=0)
        true_p = None if case.moments is None else np.linalg.norm(truths[:, 0, 5:], axis=-1)
        nearest = nearest_hypothesis(truths[:, 0], centre, levels, strength=true_p)
        counts = np.bincount(selected, minlength=len(labels))
        summary["winners"] = {labels[i]: int(c) for i, c in enumerate(counts)}
        summary["nearest_hypothesis"] = labels[int(np.bincount(nearest).argmax())]
        summary["nearest_wins"] = float(np.mean(selected == nearest))
        summary["nearest_bearing_wins"] = float(np.mean(selected % 4 == nearest % 4))
        tracks["x_all"] = results[0]["x_all"]
        tracks["loglik"] = results[0]["loglik"]
        tracks["labels"] = labels
    else:
        summary["winners"] = {}
    t = case.T * np.arange(case.steps)
    return MonteCarloResult(time_s=t, trmse_m=trmse, pcrlb_m=bound, error_m=error, nees=nees,
                            summary=summary, tracks=tracks)
