"""A batch estimate of seed 003's 4-dipole model: a robust (Huber) maximum-likelihood fit over
the whole pass, every reading once (docs/shape.md, *Batch fit*).

The fit minimises Σ ρ(e) over the 5K whitened residuals e = (z − h(X)) / σ of the one-sample
model (:meth:`core.shape.model.DipoleModel.pass_jacobian`), Huber's ρ with u =
:data:`core.tracking.unscented.HUBER_U`, by iteratively reweighted Levenberg–Marquardt
(Marquardt's diagonal damping), from each given start, keeping the lowest cost. Covariance: the
inverse Fisher information at the fit times the M-estimate's variance factor, the larger of
Huber's efficiency factor at the Gaussian and its value on the fit's own residuals,
s² = [Σ ψ(e)² / (m − p)] / [Σ ψ'(e) / m]² (Huber's sandwich), so that a model that does not fit
widens it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..tracking.unscented import HUBER_U
from .model import N_DIPOLES, DipoleModel

__all__ = ["MAX_ITER", "BatchFit", "fit_pass", "huber_efficiency"]

#: Iterations of the damped Gauss–Newton loop (seed 003's pass converges in ~10–30).
MAX_ITER = 100
#: Relative cost change below which the fit has converged.
TOL = 1e-10


@dataclass(frozen=True)
class BatchFit:
    """One pass's fit.

    Attributes
    ----------
    x : ndarray, shape (3N + 3,)
        Positions (m) and the common moment (A·m²).
    cov : ndarray, shape (3N + 3, 3N + 3)
        Covariance (module notes).
    cost : float
        Σ ρ(e) at the fit.
    misfit : float
        s², the variance factor measured on the fit's residuals (module notes).
    iterations : int
        Of the start kept.
    converged : bool
    downweighted : int
        Residuals beyond ±u (Huber weight < 1) at the fit.
    """

    x: np.ndarray
    cov: np.ndarray
    cost: float
    misfit: float
    iterations: int
    converged: bool
    downweighted: int


def huber_efficiency(u=HUBER_U):
    """E[ψ²] / E[ψ']² of Huber's ψ at the standard normal: the M-estimate's variance over the
    least-squares one (1.05 at u = 1.345, the 95 % efficiency)."""
    p = stats.norm.cdf(u) - stats.norm.cdf(-u)  # E[ψ'] = P(|e| ≤ u)
    e2 = p - 2 * u * stats.norm.pdf(u) + 2 * u**2 * stats.norm.sf(u)  # E[min(|e|, u)²]
    return float(e2 / p**2)


def _rho(e, u):
    a = np.abs(e)
    if not np.isfinite(u):  # least squares
        return 0.5 * e * e
    return np.where(a <= u, 0.5 * e * e, u * a - 0.5 * u * u)


def _one(mdl, z, x0, sigma, u, max_iter):
    ok = np.isfinite(z)

    def resid(x):
        if not np.all(np.isfinite(x)):
            return None
        try:
            h = mdl.tensor5(x, mdl.stations)
        except ValueError:  # a dipole on the gradiometer's array: not a step to take
            return None
        return np.where(ok, (z - h) / sigma, 0.0).ravel()

    x = np.array(x0, float)
    e = resid(x)
    cost = float(_rho(e, u).sum())
    lam, it, converged = 1e-3, 0, False
    for it in range(1, max_iter + 1):
        _, J = mdl.pass_jacobian(x)
        J = np.where(ok.reshape(-1, 1), J / sigma, 0.0)
        w = np.minimum(1.0, u / np.maximum(np.abs(e), 1e-300))  # IRLS weights of Huber's ψ
        A = J.T @ (w[:, None] * J)
        g = J.T @ (w * e)
        d = np.diag(A).copy()
        improved = False
        while lam < 1e12:
            try:
                step = np.linalg.solve(A + lam * np.diag(d), g)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            xn = x + step
            en = resid(xn)
            cn = np.inf if en is None else float(_rho(en, u).sum())
            if np.isfinite(cn) and cn <= cost:
                improved = True
                lam = max(lam / 10, 1e-12)
                break
            lam *= 10
        if not improved:  # no step lowers the cost: a minimum (to the damping's resolution)
            converged = True
            break
        change = (cost - cn) / max(cost, 1e-300)
        x, e, cost = xn, en, cn
        if change < TOL:
            converged = True
            break
    return x, e, cost, it, converged


def fit_pass(z5, stations, starts, sigma, *, baseline=None, u=HUBER_U, n=N_DIPOLES,
             max_iter=MAX_ITER):
    """Robust batch fit of one pass (module notes).

    Parameters
    ----------
    z5 : array_like, shape (K, 5)
        The gradiometer's readings (nT/m), each sample once; NaN rows are skipped.
    stations : array_like, shape (K, 3)
        Its positions (m).
    starts : array_like, shape (S, 3N + 3) or (3N + 3,)
        Start states (e.g. the UKF's and the NHUKF's end states); the lowest cost is kept.
    sigma : float
        Noise σ per component (nT/m).
    baseline : float or None
        The gradiometer's baseline (m): the fit models the array that made the readings (the
        point tensor differs from a 0.5 m array by ~0.3 % at 7 m, hundreds of σ).
    u : float
        Huber's threshold in σ (``inf``: least squares).

    Returns
    -------
    BatchFit
    """
    mdl = DipoleModel(np.asarray(stations, float), n_dipoles=n, baseline=baseline)
    z = np.asarray(z5, float)
    best = None
    for x0 in np.atleast_2d(np.asarray(starts, float)):
        if not np.all(np.isfinite(x0)):
            continue
        got = _one(mdl, z, x0, float(sigma), float(u), max_iter)
        if best is None or got[2] < best[2]:
            best = got
    if best is None:
        raise ValueError("fit_pass needs at least one finite start state")
    x, e, cost, it, converged = best
    ok = np.isfinite(z).ravel()
    _, J = mdl.pass_jacobian(x)
    J = J[ok] / sigma
    r = e[ok]
    m, p = r.size, x.size
    inside = np.abs(r) <= u
    psi = np.clip(r, -u, u)
    misfit = float(np.sum(psi**2) / max(m - p, 1) / max(np.mean(inside), 1.0 / m) ** 2)
    eff = huber_efficiency(u) if np.isfinite(u) else 1.0
    cov = np.linalg.pinv(J.T @ J) * max(eff, misfit)
    return BatchFit(x=x, cov=0.5 * (cov + cov.T), cost=cost, misfit=misfit, iterations=it,
                    converged=converged, downweighted=int(np.sum(~inside)))
