"""Compiled kernels of the magnetic dipole: field, gradient tensor, and their Jacobians.

A leaf: it imports only math, numpy and numba, so numba's per-file cache check covers
everything its kernels inline. Private: the inputs are validated float64 arrays
(:mod:`core.model.magnetic` is the public front), and a target within ``ON_STATION`` of a sensor
gives NaN.

Physics (spec §11; μ0/4π = 100 nT·m/A, r = sensor − target in m, m the moment in A·m²):

    B_i   = 100 (3 (m·r) r_i / r⁵ − m_i / r³)                                    nT
    G_ij  = ∂B_i/∂s_j = 300/r⁵ (m_i r_j + m_j r_i + (m·r) δ_ij) − 1500 (m·r) r_i r_j / r⁷   nT/m
    T_ijk = ∂G_ij/∂s_k = 300/r⁵ (m_i δ_jk + m_j δ_ik + m_k δ_ij)
            − 1500/r⁷ (m_i r_j r_k + m_j r_i r_k + m_k r_i r_j + (m·r)(δ_ij r_k + δ_ik r_j + δ_jk r_i))
            + 10500 (m·r) r_i r_j r_k / r⁹                                       nT/m²

The target's position enters through r = s − x, so ∂/∂x = −∂/∂s: ∂B/∂x = −G, ∂G/∂x = −T.
The state is ``[x, y, z, vx, vy, mx, my, mz]`` (8): the field does not depend on the velocity
at one instant; the motion Φ^i (constant velocity, sample interval T) adds i·T·(∂/∂x, ∂/∂y)
to the velocity columns, as for the electric dipole.

Measured components, in this order: ``B`` = (Bx, By, Bz); ``G`` = the five independent
(Gxx, Gxy, Gxz, Gyy, Gyz) (the point tensor is symmetric and traceless); ``BG`` = both.
A gradiometer of baseline L > 0 reads G_ij = (B_i(s + L/2 e_j) − B_i(s − L/2 e_j)) / L, the
differences of its magnetometers, computed from the same field kernel.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: μ0 / 4π in nT·m/A (B in nT for m in A·m² and r in m).
MU0_4PI = 100.0
#: Number of state entries of the magnetic target ``[x, y, z, vx, vy, mx, my, mz]``.
N_STATE = 8
#: Targets closer than this to a sensor (m) give NaN (the field is singular at r = 0).
ON_STATION = 1e-6
#: (i, j) of the five gradiometer components (Gxx, Gxy, Gxz, Gyy, Gyz).
G_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2))

JIT = dict(cache=True, error_model="numpy")
#: Points per parallel work item. A call with at most this many points runs the serial twin of a
#: kernel (``*_serial``): a parallel launch on one block only wakes numba's threads (seed 003's
#: filter calls the tensor ~160 times per pass on 31 sigma points × 4 dipoles).
BLOCK = 256


@nb.njit(inline="always", **JIT)
def _delta(i, j):
    return 1.0 if i == j else 0.0


@nb.njit(**JIT)
def dipole_point(r, m, with_t, b, g, db_dm, t, dg_dm):
    """Field and derivatives of one dipole at offset ``r`` (3,) = sensor − target, moment ``m``.

    Writes b (3,) = B, g (3, 3) = G = ∂B/∂s, db_dm (3, 3) = ∂B_i/∂m_k and, if ``with_t``,
    t (3, 3, 3) = T = ∂G/∂s and dg_dm (3, 3, 3) = ∂G_ij/∂m_k. Returns False (outputs NaN) if
    |r| < ON_STATION.
    """
    r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    if r2 < ON_STATION * ON_STATION:
        b[:] = np.nan
        g[:] = np.nan
        db_dm[:] = np.nan
        if with_t:
            t[:] = np.nan
            dg_dm[:] = np.nan
        return False
    inv2 = 1.0 / r2
    c3 = MU0_4PI * inv2 * math.sqrt(inv2)  # 100 / r³
    c5 = c3 * inv2  # 100 / r⁵
    c7 = c5 * inv2  # 100 / r⁷
    c9 = c7 * inv2  # 100 / r⁹
    q = m[0] * r[0] + m[1] * r[1] + m[2] * r[2]  # m·r
    for i in range(3):
        b[i] = 3.0 * q * r[i] * c5 - m[i] * c3
        for k in range(3):
            # ∂B_i/∂m_k = 100 (3 r_i r_k / r⁵ − δ_ik / r³)
            db_dm[i, k] = 3.0 * r[i] * r[k] * c5 - _delta(i, k) * c3
        for j in range(3):
            # G_ij = ∂B_i/∂s_j
            g[i, j] = (3.0 * c5 * (m[i] * r[j] + m[j] * r[i] + q * _delta(i, j))
                       - 15.0 * c7 * q * r[i] * r[j])
    if with_t:
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    d_ij, d_ik, d_jk = _delta(i, j), _delta(i, k), _delta(j, k)
                    # T_ijk = ∂G_ij/∂s_k (symmetric in i, j, k)
                    t[i, j, k] = (3.0 * c5 * (m[i] * d_jk + m[j] * d_ik + m[k] * d_ij)
                                  - 15.0 * c7 * (m[i] * r[j] * r[k] + m[j] * r[i] * r[k]
                                                 + m[k] * r[i] * r[j]
                                                 + q * (d_ij * r[k] + d_ik * r[j] + d_jk * r[i]))
                                  + 105.0 * c9 * q * r[i] * r[j] * r[k])
                    # ∂G_ij/∂m_k
                    dg_dm[i, j, k] = (3.0 * c5 * (d_ik * r[j] + d_jk * r[i] + r[k] * d_ij)
                                      - 15.0 * c7 * r[i] * r[j] * r[k])
    return True


@nb.njit(**JIT)
def baseline_point(r, m, baseline, g, dg_dx, dg_dm, rr, bb, gg, dd):
    """A gradiometer of baseline L at offset ``r``: G_ij = (B_i(r + L/2 e_j) − B_i(r − L/2 e_j))
    / L from the field kernel into g (3, 3), its derivatives with respect to the target's
    position ∂G_ij/∂x_k (−∂B_i/∂s_k = −G_ik of each magnetometer, differenced) into dg_dx
    (3, 3, 3) and ∂G_ij/∂m_k into dg_dm. ``rr`` (3,), ``bb`` (3,), ``gg`` (3, 3), ``dd`` (3, 3)
    are scratch. Returns False (outputs NaN) if a magnetometer is within ON_STATION of the
    target."""
    g[:] = 0.0
    dg_dx[:] = 0.0
    dg_dm[:] = 0.0
    ok = True
    for j in range(3):
        for sign in (1.0, -1.0):
            for k in range(3):
                rr[k] = r[k]
            rr[j] += 0.5 * sign * baseline
            ok = dipole_point(rr, m, False, bb, gg, dd, dg_dx, dg_dm) and ok
            w = sign / baseline
            for i in range(3):
                g[i, j] += w * bb[i]
                for k in range(3):
                    dg_dx[i, j, k] -= w * gg[i, k]
                    dg_dm[i, j, k] += w * dd[i, k]
    if not ok:
        g[:] = np.nan
        dg_dx[:] = np.nan
        dg_dm[:] = np.nan
    return ok


@nb.njit(nogil=True, **JIT)
def _tensor_block(states, stations, baseline, b_out, g_out, lo, hi):
    """:func:`field_and_tensor` for the points lo ≤ p < hi."""
    r, m, rr, bb = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    b, db_dm = np.empty(3), np.empty((3, 3))
    gg, dd = np.empty((3, 3)), np.empty((3, 3))
    t3, u3 = np.empty((3, 3, 3)), np.empty((3, 3, 3))
    for p in range(lo, hi):
        for k in range(3):
            m[k] = states[p, 5 + k]
        for s in range(stations.shape[0]):
            for k in range(3):
                r[k] = stations[s, k] - states[p, k]
            dipole_point(r, m, False, b, g_out[p, s], db_dm, t3, u3)
            if baseline > 0.0:
                baseline_point(r, m, baseline, g_out[p, s], t3, u3, rr, bb, gg, dd)
            for k in range(3):
                b_out[p, s, k] = b[k]


@nb.njit(parallel=True, nogil=True, **JIT)
def field_and_tensor(states, stations, baseline, b_out, g_out):
    """B (P, S, 3) nT and the gradiometer's tensor (P, S, 3, 3) nT/m (point tensor if
    ``baseline`` = 0, else the magnetometer differences) for states (P, 8), stations (S, 3)."""
    npts = states.shape[0]
    for blk in nb.prange((npts + BLOCK - 1) // BLOCK):
        _tensor_block(states, stations, baseline, b_out, g_out, blk * BLOCK,
                      min(npts, (blk + 1) * BLOCK))


@nb.njit(nogil=True, **JIT)
def field_and_tensor_serial(states, stations, baseline, b_out, g_out):
    """:func:`field_and_tensor` on the calling thread (for at most :data:`BLOCK` points)."""
    _tensor_block(states, stations, baseline, b_out, g_out, 0, states.shape[0])


@nb.njit(**JIT)
def _rows_point(x, stations, with_b, with_g, baseline, dt, h, jac, r, m, rr, bb, b, g, ga, db_dm,
                gg, dd, t3, u3):
    """Measurement rows of one state ``x`` (8,) at time offset ``dt``: h (S, C), jac (S, C, 8)
    with the motion's chain Φ^i applied (∂/∂vx += dt ∂/∂x, ∂/∂vy += dt ∂/∂y)."""
    px = x[0] + dt * x[3]
    py = x[1] + dt * x[4]
    for k in range(3):
        m[k] = x[5 + k]
    for s in range(stations.shape[0]):
        r[0] = stations[s, 0] - px
        r[1] = stations[s, 1] - py
        r[2] = stations[s, 2] - x[2]
        # the point field (B rows, and G rows without a baseline); ∂G/∂x = −T
        dipole_point(r, m, with_g and baseline <= 0.0, b, g, db_dm, t3, u3)
        sign = -1.0
        if with_g and baseline > 0.0:
            # the array's differences; ga, t3 = ∂G/∂x (already signed), u3 = ∂G/∂m
            baseline_point(r, m, baseline, ga, t3, u3, rr, bb, gg, dd)
            sign = 1.0
        else:
            ga[:] = g
        c = 0
        if with_b:
            for i in range(3):
                h[s, c] = b[i]
                for k in range(3):
                    jac[s, c, k] = -g[i, k]  # ∂B_i/∂x_k = −G_ik (point tensor)
                    jac[s, c, 5 + k] = db_dm[i, k]
                c += 1
        if with_g:
            for pair in G_PAIRS:
                i, j = pair
                h[s, c] = ga[i, j]
                for k in range(3):
                    jac[s, c, k] = sign * t3[i, j, k]
                    jac[s, c, 5 + k] = u3[i, j, k]
                c += 1
        for c2 in range(c):
            # the field does not depend on the velocity at one instant; Φ^i moves the position
            jac[s, c2, 3] = dt * jac[s, c2, 0]
            jac[s, c2, 4] = dt * jac[s, c2, 1]


@nb.njit(nogil=True, **JIT)
def _rows_block(states, stations, with_b, with_g, baseline, dt, h_out, j_out, lo, hi):
    """:func:`measurement_rows` for the points lo ≤ p < hi."""
    r, m, rr, bb, b = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    g, ga, db_dm = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    gg, dd = np.empty((3, 3)), np.empty((3, 3))
    t3, u3 = np.empty((3, 3, 3)), np.empty((3, 3, 3))
    for p in range(lo, hi):
        _rows_point(states[p], stations, with_b, with_g, baseline, dt, h_out[p], j_out[p],
                    r, m, rr, bb, b, g, ga, db_dm, gg, dd, t3, u3)


@nb.njit(parallel=True, nogil=True, **JIT)
def measurement_rows(states, stations, with_b, with_g, baseline, dt, h_out, j_out):
    """Measurements h (P, S, C) and Γ blocks ∂h(Φ^i x)/∂x (P, S, C, 8) at time offset ``dt``
    (= i·T) for states (P, 8): C = 3 (B), 5 (G) or 8 (B then G). NaN where a target is within
    ON_STATION of a magnetometer."""
    npts = states.shape[0]
    for blk in nb.prange((npts + BLOCK - 1) // BLOCK):
        _rows_block(states, stations, with_b, with_g, baseline, dt, h_out, j_out, blk * BLOCK,
                    min(npts, (blk + 1) * BLOCK))


@nb.njit(nogil=True, **JIT)
def measurement_rows_serial(states, stations, with_b, with_g, baseline, dt, h_out, j_out):
    """:func:`measurement_rows` on the calling thread (for at most :data:`BLOCK` points)."""
    _rows_block(states, stations, with_b, with_g, baseline, dt, h_out, j_out, 0, states.shape[0])
