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
#: Points per parallel work item. A call with at most this many points runs one block on the
#: calling thread (``tensor_block``, ``magnetic_rows_block``): a parallel launch on one block
#: only wakes numba's threads (seed 003's filter calls the tensor ~160 times per pass on 31
#: sigma points × 4 dipoles).
BLOCK = 256


@nb.njit(inline="always", **JIT)
def _delta(i, j):
    return 1.0 if i == j else 0.0


@nb.njit(**JIT)
def dipole_point(r, m, b, g, db_dm):
    """Field and derivatives of one dipole at offset ``r`` (3,) = sensor − target, moment ``m``.

    Writes b (3,) = B, g (3, 3) = G = ∂B/∂s, db_dm (3, 3) = ∂B_i/∂m_k. Returns False (outputs
    NaN) if |r| < ON_STATION. (The measurement rows, T = ∂G/∂s included, are
    :func:`rows_lanes`'s.)
    """
    r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    if r2 < ON_STATION * ON_STATION:
        b[:] = np.nan
        g[:] = np.nan
        db_dm[:] = np.nan
        return False
    inv2 = 1.0 / r2
    c3 = MU0_4PI * inv2 * math.sqrt(inv2)  # 100 / r³
    c5 = c3 * inv2  # 100 / r⁵
    c7 = c5 * inv2  # 100 / r⁷
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
            ok = dipole_point(rr, m, bb, gg, dd) and ok
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
def tensor_block(states, stations, baseline, b_out, g_out, lo, hi):
    """:func:`field_and_tensor` for the points lo ≤ p < hi, on the calling thread (the front's
    path for at most :data:`BLOCK` points)."""
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
            dipole_point(r, m, b, g_out[p, s], db_dm)
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
        tensor_block(states, stations, baseline, b_out, g_out, blk * BLOCK,
                      min(npts, (blk + 1) * BLOCK))


# --- Rows for the map kernels (core.kernels.gamma), LANES states side by side ------------------
#: Kernel codes of the magnetic kinds: the rows code of :mod:`core.kernels.gamma`, after the
#: electric field models (0 exact, 1 paper). The one place where a kind picks its rows.
CODE_B, CODE_G, CODE_BG = 2, 3, 4
#: Workspace rows of one component in the lane kernels: its value, then ∂/∂ the 8 states.
LANE_ROW = 1 + N_STATE
#: Most components of one station (BG: 3 + 5).
MAX_COMPONENTS = 8
#: Scratch rows of :func:`rows_lanes`: two sets (the station's point, one magnetometer of a
#: gradiometer) of r (3), m (3), m·r, 100/r³, 100/r⁵, 100/r⁷, 100/r⁹.
LANE_SCRATCH = 22
#: Entries of the lane parameters ``params``: [near, baseline L, 1/noise of B, 1/noise of G].
N_PARAMS = 4


@nb.njit(inline="always", **JIT)
def n_components(code):
    """Components per station of a magnetic rows code: 3 (B), 5 (G), 8 (BG)."""
    return 3 if code == CODE_B else (5 if code == CODE_G else 8)


@nb.njit(inline="always", **JIT)
def _powers_lanes(w, sc, lanes):
    """w[sc+6:sc+11] = m·r, 100/r³, 100/r⁵, 100/r⁷, 100/r⁹ from r = w[sc:sc+3], m = w[sc+3:sc+6]."""
    for lane in range(lanes):
        rx, ry, rz = w[sc, lane], w[sc + 1, lane], w[sc + 2, lane]
        inv2 = 1.0 / (rx * rx + ry * ry + rz * rz)
        c3 = MU0_4PI * inv2 * math.sqrt(inv2)
        w[sc + 6, lane] = w[sc + 3, lane] * rx + w[sc + 4, lane] * ry + w[sc + 5, lane] * rz
        w[sc + 7, lane] = c3
        w[sc + 8, lane] = c3 * inv2
        w[sc + 9, lane] = c3 * inv2 * inv2
        w[sc + 10, lane] = c3 * inv2 * inv2 * inv2


@nb.njit(inline="always", **JIT)
def _b_rows_lanes(w, sc, dst, lanes, weight):
    """Rows of B (3, stride LANE_ROW) at w[dst…], times ``weight``: B_i, ∂B_i/∂x_k = −G_ik,
    ∂B_i/∂v = 0, ∂B_i/∂m_k = 100 (3 r_i r_k / r⁵ − δ_ik / r³)."""
    for i in range(3):
        d = dst + LANE_ROW * i
        for lane in range(lanes):
            q, c3, c5 = w[sc + 6, lane], w[sc + 7, lane], w[sc + 8, lane]
            w[d, lane] = weight * (3.0 * q * w[sc + i, lane] * c5 - w[sc + 3 + i, lane] * c3)
            w[d + 4, lane] = 0.0
            w[d + 5, lane] = 0.0
        for k in range(3):
            dik = 1.0 if i == k else 0.0
            for lane in range(lanes):
                ri, rk = w[sc + i, lane], w[sc + k, lane]
                mi, mk = w[sc + 3 + i, lane], w[sc + 3 + k, lane]
                q, c3, c5, c7 = w[sc + 6, lane], w[sc + 7, lane], w[sc + 8, lane], w[sc + 9, lane]
                g_ik = 3.0 * c5 * (mi * rk + mk * ri + q * dik) - 15.0 * c7 * q * ri * rk
                w[d + 1 + k, lane] = -weight * g_ik  # dB_i/dx_k
                w[d + 6 + k, lane] = weight * (3.0 * ri * rk * c5 - dik * c3)  # dB_i/dm_k


@nb.njit(inline="always", **JIT)
def _g_rows_lanes(w, sc, dst, lanes, weight):
    """Rows of the point tensor's five components (stride LANE_ROW) at w[dst…], times
    ``weight``: G_ij, ∂G_ij/∂x_k = −T_ijk, ∂/∂v = 0, ∂G_ij/∂m_k (module notes)."""
    for c in range(5):
        i, j = G_PAIRS[c]
        d = dst + LANE_ROW * c
        dij = 1.0 if i == j else 0.0
        for lane in range(lanes):
            ri, rj = w[sc + i, lane], w[sc + j, lane]
            mi, mj = w[sc + 3 + i, lane], w[sc + 3 + j, lane]
            q, c5, c7 = w[sc + 6, lane], w[sc + 8, lane], w[sc + 9, lane]
            w[d, lane] = weight * (3.0 * c5 * (mi * rj + mj * ri + q * dij) - 15.0 * c7 * q * ri * rj)
            w[d + 4, lane] = 0.0
            w[d + 5, lane] = 0.0
        for k in range(3):
            dik, djk = 1.0 if i == k else 0.0, 1.0 if j == k else 0.0
            for lane in range(lanes):
                ri, rj, rk = w[sc + i, lane], w[sc + j, lane], w[sc + k, lane]
                mi, mj, mk = w[sc + 3 + i, lane], w[sc + 3 + j, lane], w[sc + 3 + k, lane]
                q, c5, c7, c9 = w[sc + 6, lane], w[sc + 8, lane], w[sc + 9, lane], w[sc + 10, lane]
                t = (3.0 * c5 * (mi * djk + mj * dik + mk * dij)
                     - 15.0 * c7 * (mi * rj * rk + mj * ri * rk + mk * ri * rj
                                    + q * (dij * rk + dik * rj + djk * ri))
                     + 105.0 * c9 * q * ri * rj * rk)
                w[d + 1 + k, lane] = -weight * t  # dG_ij/dx_k = −T_ijk
                w[d + 6 + k, lane] = weight * (3.0 * c5 * (dik * rj + djk * ri + rk * dij)
                                               - 15.0 * c7 * ri * rj * rk)  # dG_ij/dm_k


@nb.njit(inline="always", **JIT)
def _baseline_rows_lanes(w, sc, dst, lanes, weight, baseline):
    """Rows of a gradiometer of baseline L (five components, stride LANE_ROW) at w[dst…]:
    G_ij = (B_i(r + L/2 e_j) − B_i(r − L/2 e_j)) / L and its derivatives, from the field of each
    magnetometer (as :func:`baseline_point`), times ``weight``."""
    s2 = sc + 11  # the magnetometer's scratch set
    for c in range(5):
        d = dst + LANE_ROW * c
        for e in range(LANE_ROW):
            for lane in range(lanes):
                w[d + e, lane] = 0.0
    for j in range(3):
        for half in range(2):
            sign = 1.0 if half == 0 else -1.0
            for lane in range(lanes):
                for k in range(6):
                    w[s2 + k, lane] = w[sc + k, lane]
                w[s2 + j, lane] += 0.5 * sign * baseline
            _powers_lanes(w, s2, lanes)
            ws = weight * sign / baseline
            for c in range(5):
                i, jj = G_PAIRS[c]
                if jj != j:
                    continue
                d = dst + LANE_ROW * c
                for lane in range(lanes):
                    q, c3, c5 = w[s2 + 6, lane], w[s2 + 7, lane], w[s2 + 8, lane]
                    w[d, lane] += ws * (3.0 * q * w[s2 + i, lane] * c5 - w[s2 + 3 + i, lane] * c3)
                for k in range(3):
                    dik = 1.0 if i == k else 0.0
                    for lane in range(lanes):
                        ri, rk = w[s2 + i, lane], w[s2 + k, lane]
                        mi, mk = w[s2 + 3 + i, lane], w[s2 + 3 + k, lane]
                        q, c3, c5, c7 = (w[s2 + 6, lane], w[s2 + 7, lane], w[s2 + 8, lane],
                                         w[s2 + 9, lane])
                        g_ik = 3.0 * c5 * (mi * rk + mk * ri + q * dik) - 15.0 * c7 * q * ri * rk
                        w[d + 1 + k, lane] -= ws * g_ik  # −∂B_i/∂s_k of this magnetometer
                        w[d + 6 + k, lane] += ws * (3.0 * ri * rk * c5 - dik * c3)


@nb.njit(inline="always", **JIT)
def rows_lanes(w, x0, dst, sc, bad, lanes, dt, sx, sy, sz, code, params):
    """Measurement rows of one station at (sx, sy, sz) for ``lanes`` states side by side (the
    map kernels' workspace: one row of ``lanes`` values per quantity).

    States w[x0:x0+8] (their position moved by dt·(vx, vy)); rows (value, ∂/∂ the 8 states)
    of the kind's components (B then G) into w[dst + LANE_ROW·c …]; scratch w[sc:sc+LANE_SCRATCH].
    ``params`` = [near, L, 1/noise_B, 1/noise_G] (:data:`N_PARAMS`): a target within ``near``
    of the station sets w[bad] = 1 (its offset is replaced by a harmless one; the caller masks
    it); L > 0 differences the magnetometers of a gradiometer; each row is multiplied by the
    weight of its kind (1/noise: the whitened rows R^-½ H, or 1 for the rows themselves).
    """
    near, baseline, wb, wg = params[0], params[1], params[2], params[3]
    for lane in range(lanes):
        rx = sx - (w[x0, lane] + dt * w[x0 + 3, lane])  # r = sensor − target
        ry = sy - (w[x0 + 1, lane] + dt * w[x0 + 4, lane])
        rz = sz - w[x0 + 2, lane]
        close = rx * rx + ry * ry + rz * rz < near * near
        w[bad, lane] = 1.0 if close else w[bad, lane]
        w[sc, lane] = 1.0 + near if close else rx
        w[sc + 1, lane], w[sc + 2, lane] = ry, rz
        w[sc + 3, lane], w[sc + 4, lane], w[sc + 5, lane] = (w[x0 + 5, lane], w[x0 + 6, lane],
                                                             w[x0 + 7, lane])
    _powers_lanes(w, sc, lanes)
    d = dst
    if code != CODE_G:
        _b_rows_lanes(w, sc, d, lanes, wb)
        d += 3 * LANE_ROW
    if code != CODE_B:
        if baseline > 0.0:
            _baseline_rows_lanes(w, sc, d, lanes, wg, baseline)
        else:
            _g_rows_lanes(w, sc, d, lanes, wg)
