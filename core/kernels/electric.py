"""Electric field of a moving current dipole at a sensor station, and its Jacobian.

Both field models share one form. With ``r = (a, b, c) = target − station`` (m), ``D = |r|``,
the moment features ``f = (Ph cos θ, Ph sin θ, Pv, Ph)`` (A·m) and ``θ = atan2(vy, vx)``,

    E = K · N(r, f) / D⁵,    K = 1 / (4 π σ),

with N quadratic in r and linear in f.

- ``exact``: the point current dipole in a homogeneous conductor, N = 3 (p·r) r − p D² with
  p = f[:3] (spec §2). Its kernel, :func:`image_sums`, adds one source on the station's
  vertical line to thirteen sums (powers of its vertical offset over powers of its distance),
  from which :func:`sums_rows` builds the field and its Jacobian; the images of a layered sea
  add to the same sums.
- ``paper``: eqs. (10)–(12) of the source paper *as printed*. Compared with ``exact`` its
  E_x has ``−3ab`` where ``+3ab`` belongs, its E_y uses ``3a² − D²`` where ``3b² − D²``
  belongs, and its E_z uses the bare ``Ph`` (feature 3) instead of the heading-resolved
  moment. Kept only so that the paper's figures can be reproduced: its hand-derived partials
  go through the quotient rule and the heading chain (:func:`_jacobian_row`).

The kernels here assume valid input (finite, ``D > 0``, speed > 0); validation happens at the
public boundary in :mod:`core.model.validation`, the public functions in :mod:`core.model.fields`.
Like every module of :mod:`core.kernels` this one imports only math, numpy and numba (and its
sibling kernels): a leaf.
"""

from __future__ import annotations

import math

import numba as nb

#: Targets closer than this to a station (m) are "on" it: the field is singular at D = 0.
#: The public functions raise ValueError; maps (and the kernels) give NaN there.
ON_STATION = 1e-6

#: State size of the electric target ``[x, y, z, vx, vy, Ph, Pv]`` and field components per
#: station (Ex, Ey, Ez): :class:`core.Sensor` reads its counts of kind ``E`` from here, and every
#: electric kernel and workspace is sized from them (numba freezes module globals as
#: compile-time constants: the code is the one a literal would give).
N_STATES = 7
N_COMPONENTS = 3
#: Workspace rows of one component: (E_i, ∂E_i/∂X) = 1 + N_STATES.
ROW = 1 + N_STATES
#: Workspace rows of one station: N_COMPONENTS rows of ROW.
STATION_ROWS = N_COMPONENTS * ROW

#: Floating-point licence of the compiled kernels: LLVM may contract to FMA and reassociate
#: sums (measured ~2x faster, results within 1e-15 relative); NaN and inf keep their IEEE meaning.
FASTMATH = {"contract", "reassoc", "nsz", "arcp"}

#: Compile options of every kernel. ``error_model="numpy"``: a float division by zero gives inf
#: instead of raising, which keeps loops branch-free so that LLVM can vectorise them.
JIT = dict(cache=True, fastmath=FASTMATH, error_model="numpy")


@nb.njit(inline="always", **JIT)
def image_sums(rho2, c, w, eps):
    """One image of the exact dipole as thirteen sums: a source at vertical offset ``c`` and
    horizontal distance² ``rho2`` from the station, weight ``w`` (K = 1/(4πσ) times the image's
    weight), sign ``eps`` (ε = −1: a mirror image, vertical moment and ∂/∂z reversed).

    The field of a dipole p at r = (a, b, c), D² = ρ² + c², is E = w [3 (p·r) r / D⁵ − p / D³].
    Every image of a sea shares (a, b) and the moments, and differs only in c, w and ε, so the
    field of any set of images, and its Jacobian, is a fixed combination (:func:`sums_rows`) of
    thirteen sums over them (:func:`add_sums`),

        U_nj = Σ w c^j / D^(2n+1),   V_nj = Σ ε w c^j / D^(2n+1),

    in the order (U10, U20, U21, U30, U31, U32, U33, V10, V20, V21, V22, V31, V32). The whole
    space is the one image (w = K, ε = 1, c = z − h).
    """
    inv2 = 1.0 / (rho2 + c * c)
    e1 = w * inv2 * math.sqrt(inv2)  # w / D³
    e2 = e1 * inv2  # w / D⁵
    e3 = e2 * inv2  # w / D⁷
    c2, c3 = c * e2, c * e3
    cc2, cc3 = c * c2, c * c3
    return (e1, e2, c2, e3, c3, cc3, c * cc3,
            eps * e1, eps * e2, eps * c2, eps * cc2, eps * c3, eps * cc3)


@nb.njit(inline="always", **JIT)
def add_sums(s, t):
    """The sums of two sets of images (:func:`image_sums`)."""
    return (s[0] + t[0], s[1] + t[1], s[2] + t[2], s[3] + t[3], s[4] + t[4], s[5] + t[5],
            s[6] + t[6], s[7] + t[7], s[8] + t[8], s[9] + t[9], s[10] + t[10], s[11] + t[11],
            s[12] + t[12])


@nb.njit(inline="always", **JIT)
def sums_field(s, a, b, ph, pv, cos, sin):
    """E (3 components) of the images summed in ``s`` (:func:`image_sums`)."""
    big_p = ph * (cos * a + sin * b)  # P = p·r − ε Pv c, the same for every image
    f = big_p * s[1] + pv * s[9]  # Σ w (p·r) / D⁵
    return (3.0 * a * f - ph * cos * s[0], 3.0 * b * f - ph * sin * s[0],
            3.0 * (big_p * s[2] + pv * s[10]) - pv * s[7])


@nb.njit(inline="always", **JIT)
def sums_rows(s, a, b, ph, pv, cos, sin, inv_speed):
    """The three rows (E_i, ∂E_i/∂X) of the images summed in ``s`` (:func:`image_sums`), target
    − station horizontal offset (a, b), moments Ph along the heading θ (cos θ, sin θ) and Pv.

    Per image ∂_k E_i = w [3 (δ_ik p·r + p_k r_i + p_i r_k) / D⁵ − 15 (p·r) r_i r_k / D⁷] with
    p·r = P + ε Pv c, P = Ph (a cos θ + b sin θ); the target's depth moves c by ε, its vertical
    moment enters as ε Pv. ∂/∂Ph and ∂/∂Pv are the field's coefficients; the heading θ =
    atan2(vy, vx) gives ∂E/∂vx = −(sin θ / |v|) ∂E/∂θ, ∂E/∂vy = (cos θ / |v|) ∂E/∂θ.
    """
    u10, u20, u21, u30, u31, u32, u33 = s[0], s[1], s[2], s[3], s[4], s[5], s[6]
    v10, v20, v21, v22, v31, v32 = s[7], s[8], s[9], s[10], s[11], s[12]
    hr, nr = cos * a + sin * b, cos * b - sin * a  # h·r and h⊥·r, h = (cos θ, sin θ)
    p0, p1, big_p, big_n = ph * cos, ph * sin, ph * hr, ph * nr
    e = sums_field(s, a, b, ph, pv, cos, sin)
    f = big_p * u20 + pv * v21
    h = big_p * u30 + pv * v31
    hxz = big_p * u31 + pv * v32  # for ∂_x E_z, ∂_y E_z
    hzx = big_p * v31 + pv * u32  # for ∂_z E_x, ∂_z E_y
    gxy = 3.0 * (p0 * b + p1 * a) * u20 - 15.0 * a * b * h
    ex = (e[0],
          3.0 * f + 6.0 * p0 * a * u20 - 15.0 * a * a * h,
          gxy,
          3.0 * pv * a * u20 + 3.0 * p0 * v21 - 15.0 * a * hzx,
          3.0 * a * big_n * u20 + p1 * u10,  # ∂E_x/∂θ
          3.0 * a * hr * u20 - cos * u10,
          3.0 * a * v21)
    ey = (e[1],
          gxy,
          3.0 * f + 6.0 * p1 * b * u20 - 15.0 * b * b * h,
          3.0 * pv * b * u20 + 3.0 * p1 * v21 - 15.0 * b * hzx,
          3.0 * b * big_n * u20 - p0 * u10,
          3.0 * b * hr * u20 - sin * u10,
          3.0 * b * v21)
    ez = (e[2],
          3.0 * p0 * u21 + 3.0 * pv * a * v20 - 15.0 * a * hxz,
          3.0 * p1 * u21 + 3.0 * pv * b * v20 - 15.0 * b * hxz,
          3.0 * big_p * v20 + 9.0 * pv * u21 - 15.0 * (big_p * v32 + pv * u33),
          3.0 * big_n * u21,
          3.0 * hr * u21,
          3.0 * v22 - v10)
    tx, ty = -sin * inv_speed, cos * inv_speed  # ∂θ/∂vx, ∂θ/∂vy
    return ((ex[0], ex[1], ex[2], ex[3], tx * ex[4], ty * ex[4], ex[5], ex[6]),
            (ey[0], ey[1], ey[2], ey[3], tx * ey[4], ty * ey[4], ey[5], ey[6]),
            (ez[0], ez[1], ez[2], ez[3], tx * ez[4], ty * ez[4], ez[5], ez[6]))


@nb.njit(inline="always", **JIT)
def _numerator_paper(a, b, c, f0, f1, f2, f3):
    """The paper's eqs. (10)–(12) as printed, with (a, b, c) = (x, y, z − h) of the target
    relative to the station; f = (Ph cos θ, Ph sin θ, Pv, Ph). Same flat tuple as
    :func:`_local_jacobian`'s partials."""
    d2 = a * a + b * b + c * c
    q = 3.0 * a * a - d2  # the printed 3x² − D², used in both Ex and Ey
    return (
        # eq. (10): Ex = Ph cosθ (3a² − D²) − Ph sinθ 3ab + Pv 3ac
        # eq. (11): Ey = Ph sinθ (3a² − D²) + Ph cosθ 3ab + Pv 3bc
        # eq. (12): Ez = Ph 3ac + Pv (3c² − D²)   (no heading: the bare Ph, feature 3)
        f0 * q - 3.0 * f1 * a * b + 3.0 * f2 * a * c,
        f1 * q + 3.0 * f0 * a * b + 3.0 * f2 * b * c,
        3.0 * f3 * a * c + f2 * (3.0 * c * c - d2),
        4.0 * f0 * a - 3.0 * f1 * b + 3.0 * f2 * c, -2.0 * f0 * b - 3.0 * f1 * a, -2.0 * f0 * c + 3.0 * f2 * a,
        4.0 * f1 * a + 3.0 * f0 * b, -2.0 * f1 * b + 3.0 * f0 * a + 3.0 * f2 * c, -2.0 * f1 * c + 3.0 * f2 * b,
        3.0 * f3 * c - 2.0 * f2 * a, -2.0 * f2 * b, 3.0 * f3 * a + 4.0 * f2 * c,
        q, -3.0 * a * b, 3.0 * a * c, 0.0,
        3.0 * a * b, q, 3.0 * b * c, 0.0,
        0.0, 0.0, 3.0 * c * c - d2, 3.0 * a * c,
    )


@nb.njit(inline="always", **JIT)
def _jacobian_row(n, r0, r1, r2, q0, q1, q2, q3, a, b, c, d2, inv5, f0, f1, cos, sin, inv_speed):
    """One field component from its numerator ``n`` and partials: (E_i, ∂E_i/∂X (7)).

    Quotient rule ∂E/∂r = K (∂N/∂r − 5 N r / D²) / D⁵ (``inv5`` = K / D⁵); moments through
    f = (Ph cos θ, Ph sin θ, Pv, Ph) and the heading θ = atan2(vy, vx), with
    ∂θ/∂vx = −sin θ / |v| and ∂θ/∂vy = cos θ / |v|.
    """
    e = n * inv5
    five = 5.0 * e / d2
    df0 = q0 * inv5
    df1 = q1 * inv5
    de_dtheta = (df1 * f0 - df0 * f1) * inv_speed  # (dE/df0·(−Ph s) + dE/df1·(Ph c)) / |v|
    return (e, r0 * inv5 - five * a, r1 * inv5 - five * b, r2 * inv5 - five * c,
            -de_dtheta * sin, de_dtheta * cos, df0 * cos + df1 * sin + q3 * inv5, q2 * inv5)


@nb.njit(inline="always", **JIT)
def _local_jacobian(rx, ry, rz, vx, vy, ph, pv, kappa, model):
    """Field and ∂E/∂X at one target–station offset ``r`` (target − station), as three rows
    (Ex, Ey, Ez), each ``(E_i, ∂E_i/∂x, ∂E_i/∂y, ∂E_i/∂z, ∂E_i/∂vx, ∂E_i/∂vy, ∂E_i/∂Ph,
    ∂E_i/∂Pv)``. Scalars in, a tuple out: no memory, so loops over points vectorise.

    ``model`` is an index into :data:`core.model.fields.MODELS`: ``exact`` through :func:`image_sums` of the one
    image (a layered sea sums the same over its images), ``paper`` through the printed
    numerators and the quotient rule. Assumes D > 0, speed > 0.
    """
    inv_speed = 1.0 / math.sqrt(vx * vx + vy * vy)
    cos = vx * inv_speed
    sin = vy * inv_speed
    if model == 0:
        return sums_rows(image_sums(rx * rx + ry * ry, rz, kappa, 1.0), rx, ry, ph, pv, cos, sin,
                         inv_speed)
    f0 = ph * cos
    f1 = ph * sin
    t = _numerator_paper(rx, ry, rz, f0, f1, pv, ph)
    d2 = rx * rx + ry * ry + rz * rz
    inv5 = kappa / (d2 * d2 * math.sqrt(d2))
    return (
        _jacobian_row(t[0], t[3], t[4], t[5], t[12], t[13], t[14], t[15],
                      rx, ry, rz, d2, inv5, f0, f1, cos, sin, inv_speed),
        _jacobian_row(t[1], t[6], t[7], t[8], t[16], t[17], t[18], t[19],
                      rx, ry, rz, d2, inv5, f0, f1, cos, sin, inv_speed),
        _jacobian_row(t[2], t[9], t[10], t[11], t[20], t[21], t[22], t[23],
                      rx, ry, rz, d2, inv5, f0, f1, cos, sin, inv_speed),
    )


@nb.njit(inline="always", **JIT)
def _store_rows(rows, e, jac):
    """Write :func:`_local_jacobian`'s rows into ``e`` (N_COMPONENTS,) and ``jac``
    (N_COMPONENTS, N_STATES)."""
    for i in range(N_COMPONENTS):
        row = rows[i]
        e[i] = row[0]
        jac[i, 0], jac[i, 1], jac[i, 2], jac[i, 3] = row[1], row[2], row[3], row[4]
        jac[i, 4], jac[i, 5], jac[i, 6] = row[5], row[6], row[7]
