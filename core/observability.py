"""The observability matrix Γ and the measures built on it (spec §3–§4).

``Γ`` stacks ``H_{k+i} = (∂h/∂X)(Φ^i X_k) · Φ^i`` for i = 0, 1, …, rows time-major, then
station-major, then component (Ex, Ey, Ez).

- Paper rule (``steps=None``): keep the first n rows, n = number of unknown states, giving the
  paper's square Γ (eq. 15 for one station, eq. 16 for two).
- All-rows rule (``steps=N``): every component of every station at N instants, (3·S·N) × n.

Structural rank is decided on the column-scaled Γ, never on |det Γ| itself: one station has a
scale symmetry (spec §4) that makes Γ exactly singular, and float64 then returns
``|det Γ| ≈ 1e-20 · Π‖Γ_j‖`` of pure round-off.
"""

from __future__ import annotations

import numpy as np

from . import kernels, validation
from . import sea as sea_module
from .fields import MODELS

__all__ = [
    "ETA_TOL",
    "RANK_RTOL",
    "gamma",
    "log10_abs_det_gamma",
    "observability_index",
    "observable_rank",
    "unobservable_direction",
]

#: A column-scaled Γ whose smallest singular value is below ``RANK_RTOL`` times its largest is
#: rank-deficient. Measured on the paper's x–y grid (tests/test_observability.py): one station,
#: exactly singular, gives at most 3e-16 (round-off); two stations 2–15 m apart give at least
#: 4e-8 for the paper-rule Γ and 6e-4 for the all-rows Γ. 1e-10 sits between with ≥ 2.5
#: decades of margin on either side.
RANK_RTOL = 1e-10
#: Observability index η = sqrt(det Γ_sᵀΓ_s) (the Hadamard ratio for square Γ) below which a
#: point is flagged unobservable. One station's round-off gives η ≤ 4e-18 on the paper grids.
#: Below 1e-15 the float64 determinant of a unit-column matrix carries at most one significant
#: digit (relative error ~ eps/η), so such a value cannot be told from round-off either: this
#: also flags the thin curves where a dual-station paper-rule det Γ changes sign.
ETA_TOL = 1e-15


def _options(stations, T, sigma, model, known, steps, sea=None):
    """Validate everything but the states: returns the kernel arguments after ``states``
    (stations, T, κ = 1/(4πσ), model code, medium of :func:`core.sea.medium`, free columns)
    and the number of rows of Γ."""
    stations = validation.stations(stations)
    step = validation.positive("T", T, "s")
    sigma = validation.positive("sigma", sigma, "S/m")
    code = validation.model_code(model, MODELS)
    medium = sea_module.medium(sea, sigma)
    sea_module.check_column(sea, np.zeros((0, 7)), stations, model)
    free = validation.free_columns(known)
    n_rows = free.size if steps is None else 3 * stations.shape[0] * validation.steps(steps, 1)
    return (stations, step, 1.0 / (4.0 * np.pi * sigma), code, medium, free), n_rows


def _prepare(states, stations, T, sigma, model, known, steps, sea=None):
    """Validate states and options; return the kernel arguments, rows of Γ, leading shape."""
    options, n_rows = _options(stations, T, sigma, model, known, steps, sea)
    states, lead = validation.states(states)
    sea_module.check_column(sea, states, options[0], model)
    validation.no_target_on_station(states, options[0])
    return (states, *options), n_rows, lead


def gamma(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None, steps=None, known=()):
    """Observability matrix Γ.

    Parameters
    ----------
    states : array_like, shape (..., 7)
        ``[x, y, z, vx, vy, Ph, Pv]`` in m, m/s, A·m (speed > 0).
    stations : array_like, shape (S, 3)
        Station positions (m).
    T : float
        Sample interval (s), > 0.
    sigma : float
        Sea conductivity (S/m), > 0; it scales Γ by 1/σ and so shifts log10|det Γ| by a constant.
    model : {"exact", "paper"}
        Field model (see :mod:`core.fields`).
    sea : core.Sea or None
        ``None``: the whole space. A :class:`core.Sea`: air / seawater / seabed (spec §7); z is
        depth and targets and stations must lie in the water column. Only ``model="exact"``.
    steps : int or None
        ``None``: paper rule, square Γ of the first n rows. ``N ≥ 1``: all rows of N instants.
    known : sequence of str
        States treated as known (their columns dropped), e.g. ``("Ph", "Pv")``.

    Returns
    -------
    ndarray, shape (..., n, n) for the paper rule or (..., 3·S·N, n)
        n = 7 − len(known). Units: (V/m) per state unit.

    Notes
    -----
    Eq. (15) (one station) and eq. (16) (two stations) of the paper are the paper rule's
    output: Ex, Ey, Ez at k and k+1, then Ex at k+2; or all six at k, then station 1's Ex at k+1.

    Examples
    --------
    >>> import core
    >>> core.gamma([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]]).shape
    (7, 7)
    >>> core.gamma([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]], steps=4).shape
    (12, 7)
    """
    args, n_rows, lead = _prepare(states, stations, T, sigma, model, known, steps, sea)
    n_free = args[-1].size
    out = np.empty((args[0].shape[0], n_rows, n_free))
    kernels.fill_gamma(*args, n_rows, out)
    return out.reshape(lead + (n_rows, n_free))


def _square(states, stations, T, sigma, model, known, sea=None):
    args, _, lead = _prepare(states, stations, T, sigma, model, known, None, sea)
    log_det = np.empty(args[0].shape[0])
    log_eta = np.empty(args[0].shape[0])
    kernels.square_measures(*args, log_det, log_eta)
    return log_det.reshape(lead), log_eta.reshape(lead)


def log10_abs_det_gamma(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None,
                        known=()):
    """The paper's measure, log10 |det Γ| of the square (paper-rule) Γ.

    Parameters are those of :func:`gamma`.

    Returns
    -------
    ndarray, shape (...)
        log10 |det Γ| (Γ in (V/m) per state unit). ``-inf`` where det Γ is exactly zero in
        float64. For one station with all 7 states unknown the finite values returned are
        round-off (spec §4): check :func:`observability_index` against :data:`ETA_TOL` or
        :func:`observable_rank` before reading them as observability.

    Examples
    --------
    >>> import core
    >>> v = core.log10_abs_det_gamma([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]])
    >>> v.shape
    ()
    """
    return _square(states, stations, T, sigma, model, known, sea)[0]


def observability_index(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None,
                        steps=None, known=()):
    """Scale-free observability index log10 η, η = sqrt(det Γ_sᵀΓ_s) ∈ [0, 1].

    ``Γ_s`` is Γ with unit columns, so η does not depend on units or moment scale. For the
    square paper-rule Γ, η = |det Γ| / Π‖Γ_j‖ (the Hadamard ratio). η < :data:`ETA_TOL` means
    structurally unobservable; ``-inf`` where η is exactly 0.

    Returns
    -------
    ndarray, shape (...)
        log10 η (dimensionless, ≤ 0).
    """
    if steps is None:
        return _square(states, stations, T, sigma, model, known, sea)[1]
    args, n_rows, lead = _prepare(states, stations, T, sigma, model, known, steps, sea)
    npts, n = args[0].shape[0], args[-1].size
    log_eta, lns, inv = np.empty(npts), np.empty(npts), np.empty((npts, n))
    kernels.fisher_measures(*args, n_rows, log_eta, lns, inv)
    return log_eta.reshape(lead)


def _scaled_svd(g):
    """SVD of Γ with unit columns; full V so that wide Γ (fewer rows than states) still yields
    the null space. Returns ((U, s, Vᵀ), column norms (..., 1, n))."""
    norms = np.linalg.norm(g, axis=-2, keepdims=True)  # (..., 1, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        gs = np.where(norms > 0, g / norms, 0.0)
    return np.linalg.svd(gs, full_matrices=True), norms


def observable_rank(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None, steps=None, known=()):
    """Structural rank of Γ from the SVD of the column-scaled Γ.

    A singular value counts when it exceeds :data:`RANK_RTOL` times the largest. Column scaling
    removes the units (m, m/s, A·m), so the tolerance judges geometry, not scale.

    Returns
    -------
    ndarray of int, shape (...)
        Rank, at most n = 7 − len(known). One station: 6 everywhere (spec §4).

    Examples
    --------
    >>> import core
    >>> int(core.observable_rank([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]]))
    6
    >>> int(core.observable_rank([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]]))
    7
    """
    g = gamma(states, stations, T=T, sigma=sigma, model=model, sea=sea, steps=steps, known=known)
    (_, s, _), _ = _scaled_svd(g)
    return np.sum(s > RANK_RTOL * s[..., :1], axis=-1)


def unobservable_direction(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None, steps=None,
                           known=()):
    """Unit vector n (in state units) with Γ n ≈ 0: the direction the data cannot resolve.

    The right singular vector of the smallest singular value of the column-scaled Γ, mapped
    back to state units and normalised, sign fixed so that its largest-magnitude entry is
    positive. Meaningful only where :func:`observable_rank` is below n; elsewhere it is the
    least-observable direction. For one station it is ∝ (x − sx, y − sy, z − sz, vx, vy,
    3·Ph, 3·Pv) (the range ↔ source-strength ambiguity).

    Returns
    -------
    ndarray, shape (..., n)
    """
    g = gamma(states, stations, T=T, sigma=sigma, model=model, sea=sea, steps=steps, known=known)
    (_, _, vt), norms = _scaled_svd(g)
    v = vt[..., -1, :] / norms[..., 0, :]  # back from scaled coordinates to state units
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    big = np.take_along_axis(v, np.argmax(np.abs(v), axis=-1)[..., None], axis=-1)
    return v * np.sign(big)
