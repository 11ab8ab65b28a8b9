"""Seed 003's estimation model: N dipoles with one common moment, seen by a moving gradiometer.

State (3N + 3; seed 003's N = 4 gives its 15 states, eq. (14))::

    X = [r1 (3), r2 (3), …, rN (3), m (3)]      positions (m, world frame), moment (A·m²)

Each dipole has moment m; the predicted tensor is the sum of theirs (the filters' model is the
point tensor). The target is static and the platform's positions known, so the process is the
identity with a small random walk (:data:`Q_POSITION`, :data:`Q_MOMENT`). Measurement: the 5
tensor components (Gxx, Gxy, Gxz, Gyy, Gyz), nT/m, of :func:`core.gradient_tensor`, of the
current sample (``lag=0``) or seed 003's window ``[G_{k−2n}, G_{k−n}, G_k]`` (eq. (15),
``lag=n``), which uses every sample three times and so makes the covariance optimistic.

Start: not at one point, where the Jacobian has rank 6 over any number of samples
(docs/shape.md, *Model and start*): :func:`start_state` puts the dipoles at the vertices of a
regular tetrahedron (radius :data:`START_SPREAD`) about a point fix with moment m₀ / N each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.magnetic import gradient_tensor, magnetic_field, magnetic_jacobian
from ..model.validation import integer

__all__ = ["G_COMPONENTS", "cells_tensor5", "LAG", "N_DIPOLES", "P0_MOMENT_REL", "P0_POSITION", "Q_MOMENT",
           "Q_POSITION", "START_SPREAD", "DipoleModel", "collapsed", "start_state",
           "tetrahedron"]

#: Dipoles of the model (seed 003: 4, the fewest that span a volume).
N_DIPOLES = 4
#: (i, j) of the five measured tensor components (Gxx, Gxy, Gxz, Gyy, Gyz).
G_COMPONENTS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2))
#: Seed 003's window lag n (samples) of its eq. (15); not printed there.
LAG = 5
#: Radius of the starting tetrahedron (m).
START_SPREAD = 0.5
#: Prior σ of every dipole coordinate (m).
P0_POSITION = 2.0
#: Prior σ of each moment component, relative to |m₀| (the start's moment per dipole).
P0_MOMENT_REL = 0.5
#: Process noise per step: position variance (m²) and moment variance (A·m²)².
Q_POSITION = 1e-6
Q_MOMENT = 1e-2


def _states8(sources, moments):
    """Magnetic states (P, 8) of :mod:`core.model.magnetic` for dipoles at rest (velocity unused)."""
    sources = np.asarray(sources, float)
    st = np.zeros(sources.shape[:-1] + (8,))
    st[..., :3] = sources
    st[..., 5:] = moments
    return st


def dipole_field(sources, moments, stations):
    """B (P, S, 3) nT of P dipoles (positions, moments (P, 3)) at S stations:
    :func:`core.magnetic_field`, the one magnetic kernel."""
    return magnetic_field(_states8(sources, moments), stations)


def cells_tensor5(sources, moments, stations, baseline=None):
    """The 5 tensor components (K, 5) nT/m of all the cells ``sources`` (C, 3) with ``moments``
    (C, 3) summed, at ``stations`` (K, 3): what the gradiometer reads without noise."""
    G = dipole_tensor(sources, moments, stations, baseline).sum(axis=0)  # (K, 3, 3)
    i, j = zip(*G_COMPONENTS)
    return G[:, i, j]


def dipole_tensor(sources, moments, stations, baseline=None):
    """G (P, S, 3, 3) nT/m of P dipoles at S stations: :func:`core.gradient_tensor` (point
    tensor, or the finite-baseline array)."""
    return gradient_tensor(_states8(sources, moments), stations, baseline=baseline)


def tetrahedron(n=N_DIPOLES, radius=START_SPREAD):
    """Offsets of n start points on a sphere of ``radius`` (m), (n, 3): a regular tetrahedron
    for n = 4, a Fibonacci sphere otherwise."""
    if n == 4:
        v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float) / np.sqrt(3.0)
    else:
        i = np.arange(n) + 0.5
        phi = np.arccos(1 - 2 * i / n)
        th = np.pi * (1 + 5**0.5) * i
        v = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], -1)
    return radius * v


def start_state(point, moment, *, n=N_DIPOLES, spread=START_SPREAD):
    """Start mean and covariance: n dipoles about ``point`` with moment ``moment / n`` each.

    Parameters
    ----------
    point : array_like, shape (..., 3)
        A point fix of the target (m), e.g. Euler's.
    moment : array_like, shape (..., 3)
        The point fix's total moment (A·m²).
    n : int
        Dipoles.
    spread : float
        Radius of the start figure (m); 0 collapses them (rank 6: do not).

    Returns
    -------
    x0 : ndarray, shape (..., 3n + 3)
    P0 : ndarray, shape (..., 3n + 3, 3n + 3)
        Diagonal: :data:`P0_POSITION`² on positions, (:data:`P0_MOMENT_REL` · |m₀|)² on the
        moment.
    """
    point = np.asarray(point, float)
    m = np.asarray(moment, float) / n
    pos = point[..., None, :] + tetrahedron(n, spread)  # (..., n, 3)
    x0 = np.concatenate([pos.reshape(point.shape[:-1] + (3 * n,)), m], axis=-1)
    d = np.empty(point.shape[:-1] + (3 * n + 3,))
    d[..., : 3 * n] = P0_POSITION**2
    d[..., 3 * n:] = (P0_MOMENT_REL * np.linalg.norm(m, axis=-1, keepdims=True)) ** 2
    return x0, d[..., :, None] * np.eye(3 * n + 3)


def collapsed(x, n=N_DIPOLES):
    """``x`` (..., 3n + 3) with every dipole moved to their centroid."""
    x = np.array(x, float)
    pos = x[..., : 3 * n].reshape(x.shape[:-1] + (n, 3))
    x[..., : 3 * n] = np.repeat(pos.mean(axis=-2, keepdims=True), n, axis=-2).reshape(x.shape[:-1] + (3 * n,))
    return x


@dataclass(frozen=True)
class DipoleModel:
    """The measurement model of the filters (module notes).

    Parameters
    ----------
    stations : array_like, shape (K, 3)
        Gradiometer centre at each sample (m).
    n_dipoles : int
        N.
    lag : int
        0: one-sample update (5 rows); n > 0: seed 003's window [k − 2n, k − n, k] (15 rows).
    """

    stations: np.ndarray
    n_dipoles: int = N_DIPOLES
    lag: int = 0
    #: The gradiometer's baseline (m) of :func:`core.gradient_tensor`; None: the point tensor
    #: (the filters' model). The batch fit models the array (core.shape.fit).
    baseline: float | None = None

    def __post_init__(self):
        st = np.asarray(self.stations, float)
        if st.ndim != 2 or st.shape[1] != 3 or not np.all(np.isfinite(st)):
            raise ValueError(f"stations must be finite positions (K, 3) in m; got shape {st.shape}")
        object.__setattr__(self, "stations", st)
        integer("lag", self.lag, 0, what=" (0 = one-sample update)")
        integer("n_dipoles", self.n_dipoles, 1)

    @property
    def n_state(self):
        return 3 * self.n_dipoles + 3

    @property
    def window(self):
        """Sample offsets of one update: (0,) or (−2n, −n, 0)."""
        return (0,) if self.lag == 0 else (-2 * self.lag, -self.lag, 0)

    @property
    def n_meas(self):
        return 5 * len(self.window)

    def tensor5(self, x, stations):
        """The 5 tensor components (..., S, 5) of states x (..., 3N + 3) at stations (S, 3)."""
        x = np.asarray(x, float)
        n = self.n_dipoles
        lead = x.shape[:-1]
        pos = x[..., : 3 * n].reshape(-1, 3)  # (P·N, 3)
        mom = np.repeat(x[..., 3 * n:].reshape(-1, 3), n, axis=0)
        G = dipole_tensor(pos, mom, stations, self.baseline)  # (P·N, S, 3, 3)
        G = G.reshape((-1, n) + G.shape[1:]).sum(axis=1)  # sum over the dipoles
        i, j = zip(*G_COMPONENTS)
        return G[..., i, j].reshape(lead + (stations.shape[0], 5))

    def hx(self, x, k):
        """Predicted measurement at step k, (..., n_meas): the window's samples (clamped at 0;
        :meth:`window_measurements` marks those rows missing)."""
        idx = np.clip(np.asarray(self.window) + k, 0, None)
        h = self.tensor5(x, self.stations[idx])  # (..., w, 5)
        return h.reshape(h.shape[:-2] + (-1,))

    def window_measurements(self, z5):
        """Stack readings (..., K, 5) into the update's vectors (..., K, n_meas), NaN where the
        window reaches before the first sample."""
        z5 = np.asarray(z5, float)
        K = z5.shape[-2]
        out = np.full(z5.shape[:-2] + (K, self.n_meas), np.nan)
        for w, off in enumerate(self.window):
            k0 = max(0, -off)
            if k0 >= K:  # the window reaches before the first sample at every step
                continue
            out[..., k0:, 5 * w: 5 * w + 5] = z5[..., k0 + off: K + off, :]
        return out

    def _rows(self, x, stations):
        """The one-sample readings (S, 5) nT/m of one state x (3N + 3,) at stations (S, 3) and
        their exact Jacobian (5S, 3N + 3), station-major then component, from one
        :func:`core.magnetic_jacobian` call (each dipole's position columns; the moment columns
        summed over the dipoles, which share m)."""
        x = np.asarray(x, float)
        n = self.n_dipoles
        pos = x[: 3 * n].reshape(n, 3)
        h, J = magnetic_jacobian(_states8(pos, np.broadcast_to(x[3 * n:], (n, 3))), stations,
                                 sensor="G", baseline=self.baseline)  # (N, S, 5), (N, S, 5, 8)
        J = J.reshape(n, -1, 8)
        out = np.empty((J.shape[1], 3 * n + 3))
        for j in range(n):
            out[:, 3 * j: 3 * j + 3] = J[j, :, :3]
        out[:, 3 * n:] = J[:, :, 5:].sum(axis=0)
        return h.sum(axis=0), out

    def jacobian(self, x, k):
        """∂h/∂X at step k for one state x (3N + 3,): (n_meas, 3N + 3), window-major then
        component (:meth:`_rows`)."""
        return self._rows(x, self.stations[np.clip(np.asarray(self.window) + k, 0, None)])[1]

    def pass_jacobian(self, x):
        """The one-sample readings and Jacobian of one state over the whole pass (a batch fit's
        model): h (K, 5) nT/m and ∂h/∂X (5K, 3N + 3) (:meth:`_rows`; the window's lag plays no
        part: every sample once)."""
        return self._rows(x, self.stations)
