"""The observability matrix Γ and the measures built on it (spec §3–§4).

``Γ`` stacks ``H_{k+i} = (∂h/∂X)(Φ^i X_k) · Φ^i`` for i = 0, 1, …, rows time-major, then
station-major, then component (Ex, Ey, Ez).

- Paper rule (``steps=None``): keep the first n rows, n = number of unknown states, giving the
  paper's square Γ (eq. 15 for one station, eq. 16 for two).
- All-rows rule (``steps=N``): every component of every station at N instants, (3·S·N) × n.

Structural rank is decided on the column-scaled Γ, never on |det Γ| itself: one station has a
scale symmetry (spec §4) that makes Γ exactly singular, and float64 then returns
``|det Γ| ≈ 1e-20 · Π‖Γ_j‖`` of pure round-off.

One criterion (docs/rank-criterion.md): Γ has full rank where the column-scaled Γ_s has
``σ_min > RANK_RTOL · σ_max`` (:data:`RANK_RTOL`). :func:`observable_rank` counts the singular
values above that line, and every ``observable`` flag of :mod:`core` is ``observable_rank == n``
at the same point, by construction (:func:`_full_rank`). The observability index η = Π σ_i is a
*measure*, not a rank test: it can be tiny where every singular value is resolved.
"""

from __future__ import annotations

import numpy as np

from ..kernels import gamma as kernels
from ..kernels import measures
from ..model import sensors, validation

__all__ = [
    "RANK_RTOL",
    "gamma",
    "log10_abs_det_gamma",
    "observability_index",
    "observable_rank",
    "unobservable_direction",
]

#: The one rank criterion: a column-scaled Γ whose smallest singular value is not above
#: ``RANK_RTOL`` times its largest is rank-deficient (structurally unobservable). Measured on
#: the paper's x–y grid (tests/test_observability.py): one station, exactly singular, gives at
#: most 3e-16 (round-off: float64's SVD and QR resolve singular values down to ~1e-15 σ_max);
#: two stations 2–15 m apart give at least 4e-8 for the paper-rule Γ and 6e-4 for the all-rows
#: Γ. 1e-10 sits between with ≥ 2.5 decades of margin on either side.
RANK_RTOL = 1e-10
#: Safety factor of the kernels' bracket (:func:`_full_rank`). Both the bracket and the SVD are
#: exact for Γ_s + E with ‖E‖ ≲ 1e-14 (backward stability), so at the threshold the two differ
#: by ~1e-4 relative: a factor 10 is ample.
_BRACKET_MARGIN = 10.0


def _options(stations, T, sensor, known, steps, whiten=True):
    """Validate everything but the states: returns the kernel arguments after ``states``
    (stations, T, then the sensor's rows arguments κ, code, medium of
    :meth:`core.Sensor.kernel_rows`, then the free columns), the number of rows of Γ and the
    noise left to apply outside the kernels (1 for whitened magnetic rows)."""
    stations = validation.stations(stations)
    step = validation.positive("T", T, "s")
    rows, scale = sensor.kernel_rows(whiten)
    sensor.check_column(np.zeros((0, sensor.n_states)), stations)
    free = sensor.free_columns(known)
    if steps is None:
        sensors.refuse_square(sensor, "steps=None")
        n_rows = free.size
    else:
        n_rows = sensor.n_components * stations.shape[0] * validation.steps(steps, 1)
    return (stations, step, *rows, free), n_rows, scale


def _prepare(states, stations, T, sensor, known, steps, whiten=True):
    """Validate states and options; return the kernel arguments, rows of Γ, leading shape and
    the noise left to apply outside the kernels."""
    options, n_rows, scale = _options(stations, T, sensor, known, steps, whiten)
    states, lead = sensor.states(states)
    sensor.check_column(states, options[0])
    sensor.check_clear(states, options[0], steps, options[1])
    return (states, *options), n_rows, lead, scale


def gamma(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None, steps=None, known=(),
          sensor=None):
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
        Field model (see :mod:`core.model.fields`).
    sea : core.Sea or None
        ``None``: the whole space. A :class:`core.Sea`: air / seawater / seabed (spec §7); z is
        depth and targets and stations must lie in the water column. Only ``model="exact"``.
    steps : int or None
        ``None``: paper rule, square Γ of the first n rows. ``N ≥ 1``: all rows of N instants.
    known : sequence of str
        States treated as known (their columns dropped), e.g. ``("Ph", "Pv")``.
    sensor : {"E", "B", "G", "BG"} or core.Sensor or None
        The measurement model (:class:`core.Sensor`). None or ``"E"``: the electric field with
        ``sigma``, ``model``, ``sea`` (spec §6: this function, :func:`log10_abs_det_gamma` and
        :func:`observable_rank` keep them; elsewhere they are deprecated beside ``sensor=``; a
        Sensor carries those itself: do not pass both). The
        magnetic kinds take states ``(..., 8)`` = ``[x, y, z, vx, vy, mx, my, mz]`` (m, m/s,
        A·m²), need ``steps=N`` (the paper's square rule is the electric paper's) and give
        C = 3 (B, nT), 5 (G, nT/m) or 8 (BG) rows per station and instant.

    Returns
    -------
    ndarray, shape (..., n, n) for the paper rule or (..., C·S·N, n)
        n = 7 − len(known) (8 for magnetic kinds). Units: (V/m) per state unit (electric).

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
    >>> core.gamma([30, 40, 20, 2, 2, 10, 20, 30], [[0, 0, 0]], steps=2, sensor="BG").shape
    (16, 8)
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, warn=False)
    return _gamma(states, stations, T, sensor, steps, known, whiten=False)


def _gamma(states, stations, T, sensor, steps, known, whiten=True):
    """Γ of :func:`gamma`; ``whiten``: R^-½ Γ for the magnetic kinds (their rows in nT and
    nT/m made commensurate by their noise; the electric rows are never whitened: one noise)."""
    args, n_rows, lead, _ = _prepare(states, stations, T, sensor, known, steps, whiten)
    n_free = args[-1].size
    out = np.empty((args[0].shape[0], n_rows, n_free))
    kernels.fill_gamma(*args, n_rows, out)
    return out.reshape(lead + (n_rows, n_free))


def _square(states, stations, T, sensor, known):
    args, _, lead, _ = _prepare(states, stations, T, sensor, known, None)
    log_det, log_eta, log_rcond = (np.empty(args[0].shape[0]) for _ in range(3))
    measures.square_measures(*args, log_det, log_eta, log_rcond)
    return log_det.reshape(lead), log_eta.reshape(lead)


def log10_abs_det_gamma(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None,
                        known=(), sensor=None):
    """The paper's measure, log10 |det Γ| of the square (paper-rule) Γ.

    Parameters are those of :func:`gamma`.

    Returns
    -------
    ndarray, shape (...)
        log10 |det Γ| (Γ in (V/m) per state unit). ``-inf`` where det Γ is exactly zero in
        float64. For one station with all 7 states unknown the finite values returned are
        round-off (spec §4): check :func:`observable_rank` (or the ``observable`` flag of
        :func:`core.evaluate_map`, the same test) before reading them as observability.

    Examples
    --------
    >>> import core
    >>> v = core.log10_abs_det_gamma([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100], [15, 0, 100]])
    >>> v.shape
    ()
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, warn=False)
    sensors.refuse_square(sensor, "log10_abs_det_gamma")
    return _square(states, stations, T, sensor, known)[0]


def observability_index(states, stations, *, T=1.0, sigma=None, model=None, sea=None,
                        steps=None, known=(), sensor=None):
    """Scale-free observability index log10 η, η = sqrt(det Γ_sᵀΓ_s) ∈ [0, 1].

    ``Γ_s`` is Γ with unit columns, so η does not depend on units or moment scale. For the
    square paper-rule Γ, η = |det Γ| / Π‖Γ_j‖ (the Hadamard ratio); ``-inf`` where η is exactly
    0. η = Π σ_i of Γ_s is a measure, not the rank test: that is :func:`observable_rank`
    (module notes, "One criterion").

    The keywords are :func:`gamma`'s (``sigma``, ``model``, ``sea`` deprecated: pass
    ``sensor=core.Sensor("E", sigma=…, sea=…, model=…)``).

    Returns
    -------
    ndarray, shape (...)
        log10 η (dimensionless, ≤ 0).
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea)
    if steps is None:
        return _square(states, stations, T, sensor, known)[1]
    args, n_rows, lead, _ = _prepare(states, stations, T, sensor, known, steps)
    npts, n = args[0].shape[0], args[-1].size
    log_eta, lns, inv, rc = np.empty(npts), np.empty(npts), np.empty((npts, n)), np.empty(npts)
    measures.fisher_measures(*args, n_rows, log_eta, lns, inv, rc)
    return log_eta.reshape(lead)


def _scaled_svd(g):
    """SVD of Γ with unit columns; full V so that wide Γ (fewer rows than states) still yields
    the null space. Returns ((U, s, Vᵀ), column norms (..., 1, n))."""
    norms = np.linalg.norm(g, axis=-2, keepdims=True)  # (..., 1, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        gs = np.where(norms > 0, g / norms, 0.0)
    return np.linalg.svd(gs, full_matrices=True), norms


def _svd_rank(g):
    """Rank of each Γ in the stack ``g`` (..., rows, n): singular values of the column-scaled Γ
    above RANK_RTOL times the largest. The one criterion (module notes)."""
    (_, s, _), _ = _scaled_svd(g)
    return np.sum(s > RANK_RTOL * s[..., :1], axis=-1)


def _full_rank(log_rcond, states, options, n_rows):
    """``observable_rank == n`` at (P, n_states) valid states, from the kernels' log10 rcond (P,).

    rcond = 1 / (‖Γ_s‖_F ‖Γ_s⁺‖_F) brackets σ_min/σ_max in [rcond, n · rcond]
    (:mod:`core.kernels`). Where the bracket lies clear of RANK_RTOL by :data:`_BRACKET_MARGIN`
    it decides; elsewhere (a thin band, rare) Γ is rebuilt and :func:`_svd_rank` decides, so the
    flag equals :func:`observable_rank` everywhere. NaN (on a station) gives False.
    """
    n = options[-1].size
    with np.errstate(invalid="ignore"):
        out = log_rcond >= np.log10(RANK_RTOL * _BRACKET_MARGIN)
        unsure = ~out & (log_rcond + np.log10(n) > np.log10(RANK_RTOL / _BRACKET_MARGIN))
    idx = np.flatnonzero(unsure)
    if idx.size:
        g = np.empty((idx.size, n_rows, n))
        kernels.fill_gamma(np.ascontiguousarray(states[idx]), *options, n_rows, g)
        out[idx] = _svd_rank(g) == n
    return out


def observable_rank(states, stations, *, T=1.0, sigma=4.0, model="exact", sea=None, steps=None,
                    known=(), sensor=None):
    """Structural rank of Γ from the SVD of the column-scaled Γ.

    A singular value counts when it exceeds :data:`RANK_RTOL` times the largest. Column scaling
    removes the units (m, m/s, A·m), so the tolerance judges geometry, not scale. This is the
    one rank criterion: every ``observable`` flag in :mod:`core` is ``observable_rank == n``.

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
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea, warn=False)
    return _svd_rank(_gamma(states, stations, T, sensor, steps, known))  # R^-½ Γ if magnetic


def unobservable_direction(states, stations, *, T=1.0, sigma=None, model=None, sea=None, steps=None,
                           known=(), sensor=None):
    """Unit vector n (in state units) with Γ n ≈ 0: the direction the data cannot resolve.

    The right singular vector of the smallest singular value of the column-scaled Γ, mapped
    back to state units and normalised, sign fixed so that its largest-magnitude entry is
    positive. Meaningful only where :func:`observable_rank` is below n; elsewhere it is the
    least-observable direction. For one station it is ∝ (x − sx, y − sy, z − sz, vx, vy,
    3·Ph, 3·Pv) (the range ↔ source-strength ambiguity). The keywords are :func:`gamma`'s
    (``sigma``, ``model``, ``sea`` deprecated, as for :func:`observability_index`).

    Returns
    -------
    ndarray, shape (..., n)
    """
    sensor = sensors.sensor_model(sensor, sigma=sigma, model=model, sea=sea)
    (_, _, vt), norms = _scaled_svd(_gamma(states, stations, T, sensor, steps, known))
    v = vt[..., -1, :] / norms[..., 0, :]  # back from scaled coordinates to state units
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    big = np.take_along_axis(v, np.argmax(np.abs(v), axis=-1)[..., None], axis=-1)
    return v * np.sign(big)
