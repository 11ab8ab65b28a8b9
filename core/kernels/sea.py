"""The compiled image series of a layered sea (spec §7): the sums of a target–station pair's
images, in lanes of targets summed side by side. The physics, the truncation and the tail are in
docs/sea.md; the validated front is :mod:`core.model.sea` (:class:`core.Sea`, ``image_counts``).
A leaf, as every module of :mod:`core.kernels`: math, numpy, numba and its sibling kernels.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .electric import (
    JIT,
    ROW,
    STATION_ROWS,
    _local_jacobian,
    add_sums,
    image_sums,
    sums_field,
    sums_rows,
)

#: Image groups summed at most (a safeguard; reached only for η within ~1e-4 of −1).
MAX_GROUPS = 100_000


def _gauss_legendre01(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


# Gauss–Legendre rules on [0, 1] for the tail integral, (nodes, weights) padded to 8 columns:
# 4, 5 and 8 nodes, the rule chosen by the geometric tail estimate τ = |G_M| η/(1 − η)/|E|
# (largest over the lanes summed together): 4 nodes where τ ≤ 10 tol, 5 where τ ≤ 100 tol,
# else 8 (the measurements behind the thresholds: docs/sea.md, *Truncation tolerance*).
_TAIL_N = np.array([4, 5, 8])
_TAIL_TAU = np.array([10.0, 100.0])  # × tol: the largest τ of the 4- and 5-node rules
_TAIL_U = np.zeros((3, 8))
_TAIL_W = np.zeros((3, 8))
for _k, _n in enumerate(_TAIL_N):
    _TAIL_U[_k, :_n], _TAIL_W[_k, :_n] = _gauss_legendre01(_n)


@nb.njit(inline="always", **JIT)
def _group(rho2, z, sz, kw, shift):
    """The sums of the four images at index ±t (shift = 2 t D), each of weight kw = κ_water · w:
    ε = +1 at z ± shift, ε = −1 at −z ± shift (their vertical moment and ∂/∂z reversed)."""
    return add_sums(add_sums(image_sums(rho2, z + shift - sz, kw, 1.0),
                             image_sums(rho2, z - shift - sz, kw, 1.0)),
                    add_sums(image_sums(rho2, -z + shift - sz, kw, -1.0),
                             image_sums(rho2, -z - shift - sz, kw, -1.0)))


#: Rows of the series' own workspace, each one lane wide (see :func:`layered_lanes`): the pair's
#: inputs (rx, ry, z, sz, vx, vy, Ph, Pv; the series replaces vx, vy by cos θ, sin θ), the
#: previous group's field G_{m−1} (3), 1/|v|.
SEA_ROWS = 12
#: Rows of a one-pair workspace (:func:`station_rows`): the series' rows, then its STATION_ROWS (24) output rows.
PAIR_ROWS = SEA_ROWS + STATION_ROWS


@nb.njit(inline="always", **JIT)
def _load_row(w, r0, lane):
    """w[r0 : r0 + 8, lane]: one row (E_i, ∂E_i/∂X), or a pair's inputs."""
    return (w[r0, lane], w[r0 + 1, lane], w[r0 + 2, lane], w[r0 + 3, lane],
            w[r0 + 4, lane], w[r0 + 5, lane], w[r0 + 6, lane], w[r0 + 7, lane])


@nb.njit(inline="always", **JIT)
def _load(w, r0, lane):
    """The three rows (E_i, ∂E_i/∂X) of one lane from w[r0 : r0 + STATION_ROWS]."""
    return (_load_row(w, r0, lane), _load_row(w, r0 + ROW, lane), _load_row(w, r0 + 2 * ROW, lane))


@nb.njit(inline="always", **JIT)
def _store_row(w, r0, lane, row):
    w[r0, lane], w[r0 + 1, lane], w[r0 + 2, lane], w[r0 + 3, lane] = row[0], row[1], row[2], row[3]
    w[r0 + 4, lane], w[r0 + 5, lane], w[r0 + 6, lane], w[r0 + 7, lane] = row[4], row[5], row[6], row[7]


@nb.njit(inline="always", **JIT)
def _store(w, r0, lane, rows):
    """w[r0 : r0 + STATION_ROWS, lane] = the three rows (E_i, ∂E_i/∂X)."""
    _store_row(w, r0, lane, rows[0])
    _store_row(w, r0 + ROW, lane, rows[1])
    _store_row(w, r0 + 2 * ROW, lane, rows[2])


@nb.njit(inline="always", **JIT)
def _load_sums(w, r0, lane):
    """The 13 image sums of one lane from w[r0 : r0 + 13]."""
    return (w[r0, lane], w[r0 + 1, lane], w[r0 + 2, lane], w[r0 + 3, lane], w[r0 + 4, lane],
            w[r0 + 5, lane], w[r0 + 6, lane], w[r0 + 7, lane], w[r0 + 8, lane], w[r0 + 9, lane],
            w[r0 + 10, lane], w[r0 + 11, lane], w[r0 + 12, lane])


@nb.njit(inline="always", **JIT)
def _store_sums(w, r0, lane, t):
    """w[r0 : r0 + 13, lane] = the 13 image sums ``t``."""
    w[r0, lane], w[r0 + 1, lane], w[r0 + 2, lane], w[r0 + 3, lane] = t[0], t[1], t[2], t[3]
    w[r0 + 4, lane], w[r0 + 5, lane], w[r0 + 6, lane], w[r0 + 7, lane] = t[4], t[5], t[6], t[7]
    w[r0 + 8, lane], w[r0 + 9, lane], w[r0 + 10, lane] = t[8], t[9], t[10]
    w[r0 + 11, lane], w[r0 + 12, lane] = t[11], t[12]


@nb.njit(inline="always", **JIT)
def _sums_to_rows(w, r_in, r_out, n):
    """Replace the image sums at w[r_out : r_out + 13] by the rows (E_i, ∂E_i/∂X) (24)."""
    for lane in range(n):
        rx, ry, _, _, cos, sin, ph, pv = _load_row(w, r_in, lane)
        _store(w, r_out, lane, sums_rows(_load_sums(w, r_out, lane), rx, ry, ph, pv, cos, sin,
                                         w[r_in + 11, lane]))


@nb.njit(inline="always", **JIT)
def _field_of(w, r_in, lane, sums):
    """E (3 components) of image sums of the pair in ``lane``."""
    rx, ry, _, _, cos, sin, ph, pv = _load_row(w, r_in, lane)
    return sums_field(sums, rx, ry, ph, pv, cos, sin)


@nb.njit(inline="always", **JIT)
def layered_lanes(w, r_in, r_out, n, kappa, depth, eta, tol):
    """The image series of ``n`` target–station pairs side by side (lanes 0 … n − 1 of the
    workspace ``w``, a C-ordered array of shape (rows, ≥ n)), in the layered sea (D =
    ``depth``, η, tol). The one implementation of the series: the map kernels run it on
    ``LANES`` neighbouring points, every other caller on one pair (:func:`station_rows`).

    Input rows w[r_in : r_in + 8] = (rx, ry, z, sz, vx, vy, Ph, Pv) per lane: horizontal offset
    target − station, target and station depths, velocity, moments; the series overwrites vx,
    vy (by cos θ, sin θ) and uses w[r_in + 8 : r_in + 12] as scratch. Output rows
    w[r_out : r_out + 24]: per lane the three rows (E_i, ∂E_i/∂X) of
    :func:`core.fields._local_jacobian`; while the series runs, the first 13 hold the images'
    sums (:func:`core.fields.image_sums`), turned into the rows once at the end
    (:func:`core.fields.sums_rows`). Returns the number of free-space images per pair.
    Assumes valid input (both in the water column, not on the station).

    The groups m = 1, 2, … run in lockstep: all lanes take group m, until one M at which every
    lane's stop rule holds (docs/sea.md); then all close the tail from the same M. A lane run
    past its own stop only sums more of its exact series (and its stop rule holds at M too), so
    it is at least as accurate. The image positions and tail nodes depend on M and η only,
    and M is locally constant, so the Jacobian stays the exact derivative of the field.
    """
    prev, rinv = r_in + 8, r_in + 11
    # 1. m = 0: the source and its surface image; vx, vy give way to cos θ, sin θ and 1/|v|
    for lane in range(n):
        rx, ry, z, sz, vx, vy, ph, pv = _load_row(w, r_in, lane)
        inv_speed = 1.0 / math.sqrt(vx * vx + vy * vy)
        w[r_in + 4, lane], w[r_in + 5, lane], w[rinv, lane] = vx * inv_speed, vy * inv_speed, inv_speed
        rho2 = rx * rx + ry * ry
        _store_sums(w, r_out, lane, add_sums(image_sums(rho2, z - sz, kappa, 1.0),
                                             image_sums(rho2, -z - sz, kappa, -1.0)))
        w[prev, lane], w[prev + 1, lane], w[prev + 2, lane] = 0.0, 0.0, 0.0
    if eta == 0.0:
        _sums_to_rows(w, r_in, r_out, n)
        return 2
    # 2. groups |m| = 1, 2, …, until the tail can be closed (or, η < 0, neglected) in every lane;
    # squared norms: |G| ≤ c |E| as G² ≤ c² E²
    c_neg = (tol * (1.0 + eta)) ** 2
    c_pos = (12.0 * tol) ** 2
    wm = 1.0
    m = 0
    while m < MAX_GROUPS:
        m += 1
        wm *= eta
        kw, shift = kappa * wm, 2.0 * m * depth
        n_open = 0
        for lane in range(n):
            rx, ry, z, sz = w[r_in, lane], w[r_in + 1, lane], w[r_in + 2, lane], w[r_in + 3, lane]
            g = _group(rx * rx + ry * ry, z, sz, kw, shift)
            acc = add_sums(_load_sums(w, r_out, lane), g)
            _store_sums(w, r_out, lane, acc)
            g0, g1, g2 = _field_of(w, r_in, lane, g)
            t0, t1, t2 = _field_of(w, r_in, lane, acc)
            total2 = t0 * t0 + t1 * t1 + t2 * t2
            if eta < 0.0:
                done = g0 * g0 + g1 * g1 + g2 * g2 <= c_neg * total2
            else:
                d0 = g0 - eta * w[prev, lane]
                d1 = g1 - eta * w[prev + 1, lane]
                d2 = g2 - eta * w[prev + 2, lane]
                done = m >= 2 and d0 * d0 + d1 * d1 + d2 * d2 <= c_pos * total2
            w[prev, lane], w[prev + 1, lane], w[prev + 2, lane] = g0, g1, g2
            n_open += 0 if done else 1
        if n_open == 0:
            break
    if eta < 0.0:
        _sums_to_rows(w, r_in, r_out, n)
        return 2 + 4 * m
    # 3. the tail Σ_{m > M} G_m as κ ∫_{M+½}^∞ G(t) dt, G(t) = η^t (images at index t), by the
    # Gauss–Legendre rule the largest geometric tail estimate τ of the lanes calls for
    rule = 2
    if eta < 1.0:
        ratio2 = 0.0  # max |G_M|² / |E|² over the lanes
        for lane in range(n):
            t0, t1, t2 = _field_of(w, r_in, lane, _load_sums(w, r_out, lane))
            g0, g1, g2 = w[prev, lane], w[prev + 1, lane], w[prev + 2, lane]
            ratio2 = max(ratio2, (g0 * g0 + g1 * g1 + g2 * g2) / (t0 * t0 + t1 * t1 + t2 * t2))
        tau = math.sqrt(ratio2) * eta / (1.0 - eta)
        rule = 0 if tau <= _TAIL_TAU[0] * tol else (1 if tau <= _TAIL_TAU[1] * tol else 2)
    a = m + 0.5
    alpha = -math.log(eta)
    b = min(a, 1.0 / alpha) if alpha > 0.0 else a
    kap = 0.5 * alpha / math.sinh(0.5 * alpha) if alpha > 0.0 else 1.0
    for j in range(_TAIL_N[rule]):
        u = _TAIL_U[rule, j]
        t = a + b * u / (1.0 - u)
        kw = kappa * kap * _TAIL_W[rule, j] * b / ((1.0 - u) * (1.0 - u)) * math.exp(-alpha * t)
        shift = 2.0 * t * depth
        for lane in range(n):
            rx, ry, z, sz = w[r_in, lane], w[r_in + 1, lane], w[r_in + 2, lane], w[r_in + 3, lane]
            _store_sums(w, r_out, lane, add_sums(_load_sums(w, r_out, lane),
                                                 _group(rx * rx + ry * ry, z, sz, kw, shift)))
    _sums_to_rows(w, r_in, r_out, n)
    return 2 + 4 * m + 4 * _TAIL_N[rule]


@nb.njit(**JIT)
def pair_rows(w, rx, ry, z, sz, vx, vy, ph, pv, kappa, depth, eta, tol):
    """:func:`layered_lanes` on one pair, in the one-lane workspace ``w`` (PAIR_ROWS, 1): the
    three rows and the number of images. Compiled once, not inlined, so that every per-point
    caller (the field, Γ) runs the same machine code: their results agree to the last bit."""
    w[0, 0], w[1, 0], w[2, 0], w[3, 0] = rx, ry, z, sz
    w[4, 0], w[5, 0], w[6, 0], w[7, 0] = vx, vy, ph, pv
    n_img = layered_lanes(w, 0, SEA_ROWS, 1, kappa, depth, eta, tol)
    return _load(w, SEA_ROWS, 0), n_img


@nb.njit(inline="always", **JIT)
def station_rows(w, rx, ry, z, sz, vx, vy, ph, pv, kappa, model, medium):
    """The one measurement model of every kernel: the three rows (E_i, ∂E_i/∂X) of a target at
    depth z and a station at depth sz, horizontal offset (rx, ry). ``medium`` = [D, η, tol];
    D = 0 is the whole space, the single direct image (exactly :func:`_local_jacobian`).
    ``w``: a one-pair workspace, shape (PAIR_ROWS, 1), used by a layered sea only."""
    if medium[0] > 0.0:
        return pair_rows(w, rx, ry, z, sz, vx, vy, ph, pv, kappa, medium[0], medium[1], medium[2])[0]
    return _local_jacobian(rx, ry, z - sz, vx, vy, ph, pv, kappa, model)
