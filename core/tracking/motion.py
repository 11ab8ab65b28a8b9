"""Target motion for tracking: the DWNA process model and straight tracks (spec §8).

The state is the core's ``X = [x, y, z, vx, vy, Ph, Pv]`` (m, m/s, A·m; magnetic kinds
``[…, mx, my, mz]``): seed 001's horizontal dipole p along the keel is our heading-aligned
``Ph`` with ``Pv = 0`` (docs/tracking.md, *Moment parametrisation*).

Discrete white-noise acceleration (DWNA, Bar-Shalom, *Estimation with Applications to Tracking*,
§6.3.2) on each horizontal axis, with acceleration standard deviation σa (m/s²) held over each
interval T; ``z`` is constant; both moments are random walks of variance α ((A·m)² per step,
seed 001's ``Q = diag(Γ Σ Γᵀ, α I)``)::

    F = I₇ with F[0, 3] = F[1, 4] = T
    Q[x, x] = σa² T⁴/4, Q[x, vx] = σa² T³/2, Q[vx, vx] = σa² T²   (same for y, vy)
    Q[Ph, Ph] = Q[Pv, Pv] = α,  Q[z, z] = 0
"""

from __future__ import annotations

import numpy as np

from ..model import validation
from ..model.sensors import Sensor

#: State sizes of the sensor kinds: electric (7) and magnetic (8).
STATE_SIZES = (Sensor("E").n_states, Sensor("B").n_states)
#: Kinematic states ``[x, y, z, vx, vy]`` before the moments.
_KINEMATIC = 5

__all__ = ["dwna_model", "sample_tracks", "straight_track"]


def dwna_model(T=1.0, sigma_a=0.1, alpha=0.001, *, n_states=STATE_SIZES[0]):
    """Transition matrix F and process-noise covariance Q of the DWNA model.

    Parameters
    ----------
    T : float
        Sample interval (s), > 0.
    sigma_a : float
        Standard deviation of the white acceleration on each horizontal axis (m/s²), ≥ 0
        (seed 001: 0.1).
    alpha : float
        Variance of the moment random walk per step ((A·m)²), ≥ 0, on ``Ph`` and ``Pv``
        (seed 001: 0.001); on the moment vector (mx, my, mz) in (A·m²)² for magnetic states.
    n_states : {7, 8}
        7: the electric ``[x, y, z, vx, vy, Ph, Pv]``; 8: the magnetic ``[…, mx, my, mz]``
        (``core.Sensor(kind).n_states``).

    Returns
    -------
    F : ndarray, shape (n, n)
        ``X_{k+1} = F X_k + w_k``.
    Q : ndarray, shape (n, n)
        Covariance of ``w_k`` in state units squared (m², m²/s, m²/s², (A·m)²). Singular in z
        (no vertical motion), and everywhere but the moments when σa = 0.

    Examples
    --------
    >>> import core
    >>> F, Q = core.dwna_model(T=2.0, sigma_a=0.1, alpha=0.001)
    >>> float(F[0, 3]), round(float(Q[0, 0]), 12), round(float(Q[3, 3]), 12), float(Q[5, 5])
    (2.0, 0.04, 0.04, 0.001)
    """
    T = validation.positive("T", T, "s")
    sa2 = validation.positive("sigma_a", sigma_a, "m/s²", zero=True) ** 2
    alpha = validation.positive("alpha", alpha, "(A·m)² per step", zero=True)
    if n_states not in STATE_SIZES:
        raise ValueError(f"n_states must be {STATE_SIZES[0]} (electric) or {STATE_SIZES[1]} "
                         f"(magnetic); got {n_states!r}")
    F = np.eye(n_states)
    F[0, 3] = F[1, 4] = T
    Q = np.zeros((n_states, n_states))
    for p, v in ((0, 3), (1, 4)):  # Γ Σ Γᵀ with Γ = (T²/2, T)ᵀ on (position, velocity)
        Q[p, p] = sa2 * T**4 / 4.0
        Q[p, v] = Q[v, p] = sa2 * T**3 / 2.0
        Q[v, v] = sa2 * T**2
    for k in range(_KINEMATIC, n_states):
        Q[k, k] = alpha
    return F, Q


def _steps(value):
    return validation.integer("steps", value, 1, what=" (instants on the track)")


def straight_track(start, heading, speed, steps, *, T=1.0, Ph=100.0, Pv=0.0, moments=None):
    """States along a straight constant-velocity track.

    Parameters
    ----------
    start : array_like, shape (3,)
        Position at step 0 (m), ``(x, y, z)`` with z the depth (positive down, spec §7).
    heading : float
        Course θ (rad) from +x towards +y.
    speed : float
        Speed (m/s), > 0.
    steps : int
        Number of instants, ≥ 1.
    T : float
        Sample interval (s), > 0.
    Ph, Pv : float
        Moments (A·m), constant along the track (electric states).
    moments : sequence of float, optional
        The moment entries of the state instead of (Ph, Pv): ``(mx, my, mz)`` (A·m²) for the
        magnetic state ``[x, y, z, vx, vy, mx, my, mz]``, or ``(Ph, Pv)``.

    Returns
    -------
    ndarray, shape (steps, n)
        ``X_k = F^k X_0`` for k = 0 … steps − 1; n = 5 + the number of moments (7 or 8).

    Examples
    --------
    >>> import core
    >>> core.straight_track([0, 0, 5], 0.0, 2.0, 3)[:, 0].tolist()
    [0.0, 2.0, 4.0]
    >>> core.straight_track([0, 0, 5], 0.0, 2.0, 3, moments=(1.0, 2.0, 3.0)).shape
    (3, 8)
    """
    start = validation.as_array("start", start)
    if start.shape != (3,):
        raise ValueError(f"start must be a position (x, y, z) in m, shape (3,); got shape {start.shape}")
    validation.finite("start", start)
    heading = float(heading)
    if not np.isfinite(heading):
        raise ValueError(f"heading must be a finite angle (rad); got {heading!r}")
    speed = validation.positive("speed", speed, "m/s")
    steps = _steps(steps)
    T = validation.positive("T", T, "s")
    if moments is None:
        for name, v in (("Ph", Ph), ("Pv", Pv)):
            if not np.isfinite(float(v)):
                raise ValueError(f"{name} must be a finite moment (A·m); got {v!r}")
        mom = np.array([float(Ph), float(Pv)])
    else:
        mom = validation.as_array("moments", moments)
        if mom.ndim != 1 or _KINEMATIC + mom.size not in STATE_SIZES:
            raise ValueError("moments must be (Ph, Pv) in A·m or (mx, my, mz) in A·m²; got "
                             f"shape {mom.shape}")
        validation.finite("moments", mom)
    t = T * np.arange(steps)
    vx, vy = speed * np.cos(heading), speed * np.sin(heading)
    out = np.empty((steps, _KINEMATIC + mom.size))
    out[:, 0] = start[0] + vx * t
    out[:, 1] = start[1] + vy * t
    out[:, 2] = start[2]
    out[:, 3], out[:, 4] = vx, vy
    out[:, _KINEMATIC:] = mom
    return out


def sample_tracks(x0, F, Q, steps, rng):
    """Random tracks of the linear-Gaussian model ``X_{k+1} = F X_k + w_k``, ``w_k ~ N(0, Q)``.

    Parameters
    ----------
    x0 : array_like, shape (..., n)
        States at step 0 (one track per leading index); n = 7 electric, 8 magnetic.
    F, Q : array_like, shape (n, n)
        From :func:`dwna_model`; Q symmetric positive semi-definite.
    steps : int
        Number of instants, ≥ 1.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (..., steps, n)
    """
    x0 = validation.as_array("x0", x0)
    if x0.ndim < 1 or x0.shape[-1] not in STATE_SIZES:
        raise ValueError(f"x0 must have shape (..., n), n in {STATE_SIZES}; got shape {x0.shape}")
    n = x0.shape[-1]
    F, Q = np.asarray(F, float), np.asarray(Q, float)
    if F.shape != (n, n) or Q.shape != (n, n):
        raise ValueError(f"F and Q must be {n} × {n}; got {F.shape} and {Q.shape}")
    steps = _steps(steps)
    # Q may be singular (z, or σa = 0): factor by eigen-decomposition instead of Cholesky.
    w, V = np.linalg.eigh(0.5 * (Q + Q.T))
    if w.min() < -1e-12 * max(w.max(), 1.0):
        raise ValueError("Q must be positive semi-definite")
    root = V * np.sqrt(np.clip(w, 0.0, None))  # (n, n): root @ rootᵀ = Q
    out = np.empty(x0.shape[:-1] + (steps, n))
    out[..., 0, :] = x0
    noise = rng.standard_normal(x0.shape[:-1] + (steps - 1, n)) @ root.T
    for k in range(1, steps):
        out[..., k, :] = out[..., k - 1, :] @ F.T + noise[..., k - 1, :]
    return out
