"""Unscented Kalman filters, generic over the process and measurement functions: the UKF and
the NHUKF (Huber-robust update; seed 003 §2, Karlgaard & Schaub).

Every function works on a *stack* of N independent filters (leading axis N: Monte-Carlo runs),
as :mod:`core.tracking.filters` does for the EKF, so one step is one call of the measurement function on
an (N, 2n + 1, n) array of sigma points. The filters know nothing of the physics: the process
function ``fx`` and the measurement function ``hx`` are callables on (..., n) arrays, e.g. a
:class:`core.SensorModel`'s ``h`` (electric, seed 001) or :class:`core.shape.DipoleModel`'s
(magnetic gradient tensor, seed 003).

Sigma points (scaled unscented transform, Julier 2002; the convention of Stone Soup's
``gauss2sigma``): with n states, λ = α²(n + κ) − n and c = n + λ,

    X₀ = x,   X_i = x + √c L_i,   X_{n+i} = x − √c L_i   (L = chol(P), L_i its i-th column)
    Wm₀ = λ / c,   Wc₀ = λ / c + (1 − α² + β),   Wm_i = Wc_i = 1 / (2c)

Defaults :data:`ALPHA` = 1, :data:`BETA` = 2, :data:`KAPPA` = 0: λ = 0, every weight ≥ 0
(docs/shape.md, *Filters*).

Update (Stone Soup's ``UnscentedKalmanUpdater``): fresh sigma points of the prediction,
ẑ = Σ Wm Z_i, S = Σ Wc (Z_i − ẑ)(Z_i − ẑ)ᵀ + R̃, P_xz = Σ Wc (X_i − x)(Z_i − ẑ)ᵀ,
K = P_xz S⁻¹, x ← x + K (z − ẑ), P ← P − K S Kᵀ.

NHUKF (seed 003 eqs. (3)–(13)): the update is the Huber M-estimate of the regression
[z; x̂⁻] = [h(x); x] + noise, whitened by blockdiag(R, P⁻)^½. With the prior residual set to zero
(seed 003 eq. (12): Ψ_x = I) one iteration reduces to the UKF update with R replaced by

    R̃ = R^½ Ψ⁻¹ R^½ᵀ,   Ψ = diag ψ(e_i),   ψ(e) = min(1, u / |e|),   e = R^-½ (z − ẑ)

(R^½ the lower Cholesky factor): a component whose whitened residual exceeds the threshold u is
counted with its noise inflated by |e| / u, which caps its influence (Huber's ρ is quadratic
inside ±u and linear outside). u = 1.345 (:data:`HUBER_U`, 95 % efficiency at the Gaussian) unless
set; u = inf is the UKF exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ALPHA", "BETA", "HUBER_U", "KAPPA", "UkfRun", "huber_weights", "run_ukf",
           "sensor_hx", "sigma_points", "ukf_predict", "ukf_update"]

#: Default sigma-point spread α, prior-distribution parameter β (2: Gaussian) and secondary
#: scaling κ of the scaled unscented transform (see the module notes).
ALPHA = 1.0
BETA = 2.0
KAPPA = 0.0
#: Default Huber threshold u (whitened units): 95 % asymptotic efficiency at the Gaussian.
HUBER_U = 1.345


def _check_params(alpha, beta, kappa, n):
    for name, v in (("alpha", alpha), ("beta", beta), ("kappa", kappa)):
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite; got {v!r}")
    if alpha <= 0:
        raise ValueError(f"alpha must be > 0 (sigma-point spread); got {alpha!r}")
    if alpha**2 * (n + kappa) <= 0:
        raise ValueError(f"alpha² (n + kappa) must be > 0 (n = {n} states); got alpha={alpha!r}, "
                         f"kappa={kappa!r}")


def _sqrt_psd(P):
    """Lower Cholesky factors of the stack P (N, n, n); where one is not positive definite
    (round-off in a nearly singular P), a symmetric root V diag(√max(w, 0)) from eigh."""
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        out = np.empty_like(P)
        for f in range(P.shape[0]):
            try:
                out[f] = np.linalg.cholesky(P[f])
            except np.linalg.LinAlgError:
                w, V = np.linalg.eigh(0.5 * (P[f] + P[f].T))
                out[f] = V * np.sqrt(np.clip(w, 0.0, None))
        return out


def sigma_points(x, P, *, alpha=ALPHA, beta=BETA, kappa=KAPPA):
    """Scaled sigma points and weights of N Gaussians.

    Parameters
    ----------
    x : array_like, shape (N, n)
        Means.
    P : array_like, shape (N, n, n)
        Covariances (symmetric positive semi-definite).
    alpha, beta, kappa : float
        Spread α > 0, distribution parameter β, secondary scaling κ (module notes).

    Returns
    -------
    X : ndarray, shape (N, 2n + 1, n)
        Sigma points: the mean, then + and − √c times each column of chol(P).
    wm, wc : ndarray, shape (2n + 1,)
        Mean and covariance weights.

    Examples
    --------
    >>> import numpy as np
    >>> X, wm, wc = sigma_points(np.zeros((1, 2)), np.eye(2)[None])
    >>> np.round(X[0], 4).tolist() == [[0, 0], [1.4142, 0], [0, 1.4142], [-1.4142, 0], [0, -1.4142]]
    True
    >>> wm.tolist(), wc.tolist()
    ([0.0, 0.25, 0.25, 0.25, 0.25], [2.0, 0.25, 0.25, 0.25, 0.25])
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    n = x.shape[-1]
    _check_params(alpha, beta, kappa, n)
    lam = alpha**2 * (n + kappa) - n
    c = n + lam
    L = _sqrt_psd(P) * np.sqrt(c)  # (N, n, n)
    Lt = np.swapaxes(L, -1, -2)  # rows = columns of L
    X = np.concatenate([x[:, None, :], x[:, None, :] + Lt, x[:, None, :] - Lt], axis=1)
    wm = np.full(2 * n + 1, 0.5 / c)
    wm[0] = lam / c
    wc = wm.copy()
    wc[0] = lam / c + (1.0 - alpha**2 + beta)
    return X, wm, wc


def ukf_predict(x, P, fx, Q, *, alpha=ALPHA, beta=BETA, kappa=KAPPA):
    """Time update of N UKFs: the unscented transform of (x, P) through ``fx``, plus Q.

    Parameters
    ----------
    x : ndarray, shape (N, n)
    P : ndarray, shape (N, n, n)
    fx : callable
        Process function on (..., n) arrays, returning (..., n); e.g. ``lambda X: X @ F.T``.
    Q : array_like, shape (n, n) or (N, n, n)
        Additive process-noise covariance.
    alpha, beta, kappa : float
        Sigma-point parameters.

    Returns
    -------
    x, P : ndarray, shapes (N, n), (N, n, n)
    """
    X, wm, wc = sigma_points(x, P, alpha=alpha, beta=beta, kappa=kappa)
    Y = np.asarray(fx(X), dtype=float)  # (N, 2n+1, n)
    xm = np.einsum("s,nsi->ni", wm, Y)
    d = Y - xm[:, None, :]
    Pp = np.einsum("s,nsi,nsj->nij", wc, d, d) + np.asarray(Q, dtype=float)
    return xm, 0.5 * (Pp + np.swapaxes(Pp, -1, -2))


def huber_weights(e, u=HUBER_U):
    """Huber's ψ(e)/e weights of whitened residuals: min(1, u / |e|).

    Parameters
    ----------
    e : array_like
        Whitened residuals (dimensionless).
    u : float
        Threshold > 0; inf gives weights 1 everywhere (least squares).

    Returns
    -------
    ndarray, shape of ``e``
        Weights in (0, 1]; 1 where |e| ≤ u.

    Examples
    --------
    >>> huber_weights([0.5, -2.69, 13.45], u=1.345).tolist()
    [1.0, 0.5, 0.1]
    """
    e = np.abs(np.asarray(e, dtype=float))
    u = np.asarray(u, dtype=float)
    if not np.all(u > 0):
        raise ValueError(f"Huber threshold u must be > 0 (inf = plain UKF); got {u!r}")
    with np.errstate(divide="ignore"):
        return np.where(e > u, u / np.where(e > u, e, 1.0), 1.0)


def ukf_update(x, P, z, hx, R, *, u=np.inf, alpha=ALPHA, beta=BETA, kappa=KAPPA):
    """Measurement update of N UKFs; with a finite Huber threshold ``u``, the NHUKF's.

    Parameters
    ----------
    x : ndarray, shape (N, n)
        Predicted means.
    P : ndarray, shape (N, n, n)
        Predicted covariances.
    z : array_like, shape (N, m)
        Measurements.
    hx : callable
        Measurement function on (..., n) arrays returning (..., m).
    R : array_like, shape (m, m)
        Measurement-noise covariance (positive definite).
    u : float or array_like, shape (N,)
        Huber threshold (whitened units); inf (default) is the plain UKF, 1.345 the NHUKF's.
        One per filter runs UKFs and NHUKFs in one stack (one measurement call a step).
    alpha, beta, kappa : float
        Sigma-point parameters.

    Returns
    -------
    x, P : ndarray, shapes (N, n), (N, n, n)
        Posterior means and covariances.
    nu : ndarray, shape (N, m)
        Innovations z − ẑ.
    S : ndarray, shape (N, m, m)
        Innovation covariances with the noise actually used (R̃).
    psi : ndarray, shape (N, m)
        Huber weights of the whitened residuals (all 1 for the UKF).
    """
    X, wm, wc = sigma_points(x, P, alpha=alpha, beta=beta, kappa=kappa)
    Z = np.asarray(hx(X), dtype=float)  # (N, 2n+1, m)
    z = np.asarray(z, dtype=float)
    R = np.asarray(R, dtype=float)
    zm = np.einsum("s,nsr->nr", wm, Z)
    dz = Z - zm[:, None, :]
    dx = X - X[:, :1, :]  # Stone Soup: deviations from the central point (the mean)
    Pzz = np.einsum("s,nsr,nsq->nrq", wc, dz, dz)
    Pxz = np.einsum("s,nsi,nsr->nir", wc, dx, dz)
    nu = z - zm
    Lr = np.linalg.cholesky(R)
    u = np.asarray(u, dtype=float)
    if np.all(np.isinf(u)):
        psi = np.ones_like(nu)
        Rt = R
    else:
        e = np.linalg.solve(Lr, nu.T).T  # whitened residuals R^-½ (z − ẑ), (N, m)
        psi = huber_weights(e, u[..., None] if u.ndim else u)
        Rt = np.einsum("ra,na,qa->nrq", Lr, 1.0 / psi, Lr)  # R^½ Ψ⁻¹ R^½ᵀ
    S = Pzz + Rt
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(Pxz, -1, -2)), -1, -2)  # P_xz S⁻¹ (S symmetric)
    xu = x + np.einsum("nir,nr->ni", K, nu)
    Pu = P - np.einsum("nir,nrq,njq->nij", K, S, K)
    return xu, 0.5 * (Pu + np.swapaxes(Pu, -1, -2)), nu, S, psi


@dataclass(frozen=True)
class UkfRun:
    """Output of :func:`run_ukf` for N filters over K steps.

    Attributes
    ----------
    x : ndarray, shape (N, K, n)
        Posterior means.
    P : ndarray, shape (N, K, n, n)
        Posterior covariances.
    psi : ndarray, shape (N, K, m)
        Huber weights used at each step (1 for the UKF; NaN where a windowed step had fewer rows).
    nees : ndarray, shape (N, K) or None
        (x̂ − x)ᵀ P⁻¹ (x̂ − x) over all n states when the true states were given.
    """

    x: np.ndarray
    P: np.ndarray
    psi: np.ndarray
    nees: np.ndarray | None


def run_ukf(x0, P0, zs, hx, R, *, fx=None, Q=None, u=np.inf, truth=None, alpha=ALPHA,
            beta=BETA, kappa=KAPPA):
    """Run N UKFs (or NHUKFs) over K steps of their own measurements.

    At step 0 each filter updates its prior (x0, P0) with zs[:, 0]; from step 1 on it predicts
    (``fx``, ``Q``) and updates.

    Parameters
    ----------
    x0 : array_like, shape (N, n)
    P0 : array_like, shape (n, n) or (N, n, n)
    zs : array_like, shape (N, K, m)
        Measurements; NaN entries are missing (a row set per step must be the same for all N).
    hx : callable
        ``hx(X, k)``: the measurement function at step k on (..., n) arrays, returning
        (..., m) (time-varying: a moving platform's sensor positions).
    R : array_like, shape (m, m)
        Measurement-noise covariance.
    fx : callable, optional
        Process function on (..., n) arrays; default the identity (a static state).
    Q : array_like, shape (n, n), optional
        Process-noise covariance; default zero.
    u : float or array_like, shape (N,)
        Huber threshold; inf (default) = UKF, 1.345 = seed 003's NHUKF; one per filter to run
        both kinds in one stack.
    truth : array_like, shape (N, K, n), optional
        True states, for the NEES.
    alpha, beta, kappa : float
        Sigma-point parameters.

    Returns
    -------
    UkfRun

    Notes
    -----
    Rows of ``zs[:, k]`` that are NaN (the same rows in every filter) are left out of the step's
    update, with the matching rows and columns of R: seed 003's lagged window has fewer readings
    at its first steps.
    """
    x = np.array(x0, dtype=float)
    zs = np.asarray(zs, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"x0 must have shape (N, n); got {x.shape}")
    n_f, n = x.shape
    if zs.ndim != 3 or zs.shape[0] != n_f:
        raise ValueError(f"zs must have shape (N, K, m) with N = {n_f}; got {zs.shape}")
    R = np.asarray(R, dtype=float)
    m = zs.shape[2]
    if R.shape != (m, m):
        raise ValueError(f"R must have shape ({m}, {m}) for m = {m} measurements; got {R.shape}")
    P = np.broadcast_to(np.asarray(P0, dtype=float), (n_f, n, n)).copy()
    Q = np.zeros((n, n)) if Q is None else np.asarray(Q, dtype=float)
    fx = (lambda X: X) if fx is None else fx
    if truth is not None:
        truth = np.asarray(truth, dtype=float)
        if truth.shape != (n_f, zs.shape[1], n):
            raise ValueError(f"truth must have shape {(n_f, zs.shape[1], n)}; got {truth.shape}")
    k_steps = zs.shape[1]
    xs = np.empty((n_f, k_steps, n))
    Ps = np.empty((n_f, k_steps, n, n))
    psis = np.full((n_f, k_steps, m), np.nan)
    kw = dict(alpha=alpha, beta=beta, kappa=kappa)
    for k in range(k_steps):
        if k > 0:
            x, P = ukf_predict(x, P, fx, Q, **kw)
        rows = np.flatnonzero(np.isfinite(zs[0, k]))
        if rows.size:
            h_k = (lambda X, k=k: hx(X, k)) if rows.size == m else (
                lambda X, k=k, rows=rows: hx(X, k)[..., rows])
            x, P, _, _, psi = ukf_update(x, P, zs[:, k, rows], h_k, R[np.ix_(rows, rows)], u=u, **kw)
            psis[:, k, rows] = psi
        xs[:, k], Ps[:, k] = x, P
    nees = None
    if truth is not None:
        err = xs - truth
        nees = np.einsum("nki,nki->nk", err, np.linalg.solve(Ps, err[..., None])[..., 0])
    return UkfRun(x=xs, P=Ps, psi=psis, nees=nees)


def sensor_hx(sensors):
    """The measurement function ``hx(X, k)`` of a :class:`core.SensorModel` (electric, seed 001)
    for :func:`run_ukf`.

    The field of a layered sea exists only in the water column, and a sigma point may fall
    outside it: its depth is clipped into [0, D] first, as :mod:`core.tracking.filters` guards the EKF's
    linearisation point. In the whole space nothing is clipped.

    Parameters
    ----------
    sensors : core.SensorModel

    Returns
    -------
    callable
        ``hx(X, k)`` → ``sensors.h(X)`` (..., m), V/m; k is unused (fixed stations).
    """
    lo, hi = sensors.depth_range

    def hx(X, k):
        if np.isfinite(lo) or np.isfinite(hi):
            X = np.array(X, dtype=float)
            X[..., 2] = np.clip(X[..., 2], lo, hi)
        return sensors.h(X)

    return hx
