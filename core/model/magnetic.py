"""Magnetic dipole sensing (spec §11): field, gradient tensor, invariants, Euler location.

Validated numpy-shaped fronts of :mod:`core.kernels.magnetic` (the one copy of the physics).
The magnetic target's state is ``[x, y, z, vx, vy, mx, my, mz]`` (8): position (m), horizontal
velocity (m/s, as in the electric model; the field at one instant does not depend on it) and a
free moment vector (A·m²). μ0/4π = 100 nT·m/A; fields in nT, tensors in nT/m. Seawater does
not change a magnetostatic field (μr ≈ 1).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..kernels import gamma as gk
from ..kernels import magnetic as mk
from . import validation

__all__ = [
    "MAGNETIC_STATE_NAMES", "MAGNETIC_STATE_UNITS", "TensorInvariants", "euler_locate",
    "gradient_tensor", "magnetic_field", "magnetic_jacobian", "tensor_invariants",
]

#: Order of the magnetic target's state.
MAGNETIC_STATE_NAMES = ("x", "y", "z", "vx", "vy", "mx", "my", "mz")
#: Its units, in the same order.
MAGNETIC_STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "A·m²", "A·m²", "A·m²")
#: Components each magnetic sensor kind reports, in measurement order.
MAGNETIC_COMPONENTS = {
    "B": ("Bx", "By", "Bz"),
    "G": ("Gxx", "Gxy", "Gxz", "Gyy", "Gyz"),
    "BG": ("Bx", "By", "Bz", "Gxx", "Gxy", "Gxz", "Gyy", "Gyz"),
}
#: Rows code of each magnetic kind in :mod:`core.kernels.gamma` (the electric kinds use their
#: field model's code, 0 exact, 1 paper): the one table of it (core.model.sensors reads it).
MAGNETIC_CODES = {"B": mk.CODE_B, "G": mk.CODE_G, "BG": mk.CODE_BG}
#: Relative reciprocal condition number below which :func:`euler_locate` calls G singular.
EULER_RCOND = 1e-10


def states(value):
    """Magnetic states as a contiguous (P, 8) float64 array, and the leading shape."""
    arr = validation.as_array("states", value)
    if arr.ndim < 1 or arr.shape[-1] != mk.N_STATE:
        raise ValueError(
            "magnetic states must have shape (..., 8) = [x, y, z, vx, vy, mx, my, mz] "
            f"(m, m/s, A·m²); got shape {arr.shape}"
        )
    validation.finite("states", arr)
    return np.ascontiguousarray(arr.reshape(-1, mk.N_STATE)), arr.shape[:-1]


def baseline_value(baseline):
    """None or 0 (the point tensor), or a gradiometer baseline L > 0 (m); returns a float."""
    return 0.0 if baseline is None else validation.positive("baseline", baseline, "m", zero=True)


def check_distances(flat, stations, baseline):
    """ValueError if a target is on a station, or within a gradiometer's array."""
    d = validation.station_distances(flat, stations)
    limit = max(validation.ON_STATION, baseline)
    if np.any(d < limit):
        p, s = np.argwhere(d < limit)[0]
        what = ("on the station: the dipole field is singular at r = 0" if baseline == 0.0 else
                f"within the gradiometer's baseline {baseline} m (its magnetometers sit "
                f"±{baseline / 2} m along each axis)")
        raise ValueError(
            f"target position {validation.point_text(flat[p, :3])} m is {what}; station {s} at "
            f"{validation.point_text(stations[s])} m. Move the target or mask such points"
        )


def _checked(states_value, stations_value, baseline, dt=0.0):
    """Validated states (P, 8), their leading shape, stations (S, 3) and baseline (m): no target
    within the gradiometer's array (or on a station) at time offset ``dt``."""
    flat, lead = states(states_value)
    stations = validation.stations(stations_value)
    baseline = baseline_value(baseline)
    moved = flat.copy()
    moved[:, :2] += dt * flat[:, 3:5]
    check_distances(moved, stations, baseline)
    return flat, lead, stations, baseline


def _field_and_tensor(states_value, stations_value, baseline):
    flat, lead, stations, baseline = _checked(states_value, stations_value, baseline)
    n_s = stations.shape[0]
    b = np.empty((flat.shape[0], n_s, 3))
    g = np.empty((flat.shape[0], n_s, 3, 3))
    if flat.shape[0] > mk.BLOCK:
        mk.field_and_tensor(flat, stations, baseline, b, g)
    else:  # one block: on this thread (a parallel launch only wakes numba's threads)
        mk.tensor_block(flat, stations, baseline, b, g, 0, flat.shape[0])
    return b.reshape(lead + (n_s, 3)), g.reshape(lead + (n_s, 3, 3))


def magnetic_field(states, stations):
    """Magnetic flux density of the target's dipole at each station.

    Parameters
    ----------
    states : array_like, shape (..., 8)
        ``[x, y, z, vx, vy, mx, my, mz]``: target position (m), horizontal velocity (m/s;
        unused at one instant) and moment (A·m²).
    stations : array_like, shape (S, 3)
        Sensor positions (m), S ≥ 1.

    Returns
    -------
    B : ndarray, shape (..., S, 3)
        ``(Bx, By, Bz)`` in nT: ``B = 100 (3 (m·r̂) r̂ − m) / r³`` with r = station − target
        (μ0/4π = 100 nT·m/A).

    Raises
    ------
    ValueError
        Wrong shapes, non-finite values, or a target on a station (r = 0, where B is singular).

    Examples
    --------
    On the moment's axis B = 2 · 100 m / r³:

    >>> import numpy as np, core
    >>> B = core.magnetic_field([0, 0, 0, 1, 0, 0, 0, 1000], [[0, 0, 10]])
    >>> bool(np.allclose(B, [[0, 0, 200]], rtol=1e-14, atol=0))
    True
    """
    return _field_and_tensor(states, stations, None)[0]


def gradient_tensor(states, stations, *, baseline=None):
    """Magnetic gradient tensor G_ij = ∂B_i/∂s_j at each station (derivative with respect to the
    sensor position).

    Parameters
    ----------
    states, stations
        As for :func:`magnetic_field`.
    baseline : float or None
        ``None`` (or 0): the point tensor, symmetric and traceless. ``L > 0`` (m): a
        gradiometer array of magnetometers ±L/2 along each axis about the station, reading
        G_ij = (B_i(s + L/2 e_j) − B_i(s − L/2 e_j)) / L (seed 003: L = 0.5 m). It differs from
        the point tensor by O((L/r)²) (spec §11: ≈ 0.83 (L/r)²); targets must be farther than L.

    Returns
    -------
    G : ndarray, shape (..., S, 3, 3)
        In nT/m. Point tensor: ``(300/r⁵)(m_i r_j + m_j r_i + (m·r) δ_ij − 5 (m·r) r_i r_j / r²)``.

    Raises
    ------
    ValueError
        As :func:`magnetic_field`; a negative or non-finite baseline; a target within the
        baseline of a station.

    Examples
    --------
    >>> import numpy as np, core
    >>> G = core.gradient_tensor([1, 2, 3, 1, 0, 10, -20, 30], [[0, 0, 0]])
    >>> bool(np.allclose(G, np.swapaxes(G, -1, -2))), bool(abs(np.trace(G[0])) < 1e-12)
    (True, True)
    """
    return _field_and_tensor(states, stations, baseline)[1]


def magnetic_jacobian(states, stations, *, sensor="B", baseline=None):
    """Measurements of a magnetic sensor kind and their exact Jacobian with respect to the state.

    Parameters
    ----------
    states, stations
        As for :func:`magnetic_field`.
    sensor : {"B", "G", "BG"}
        ``"B"``: (Bx, By, Bz) nT; ``"G"``: (Gxx, Gxy, Gxz, Gyy, Gyz) nT/m; ``"BG"``: both, B first.
    baseline : float or None
        The gradiometer's baseline (m), as for :func:`gradient_tensor`.

    Returns
    -------
    h : ndarray, shape (..., S, C)
        The C = 3, 5 or 8 measured components at each station.
    J : ndarray, shape (..., S, C, 8)
        ``J[..., s, c, j] = ∂h_c(station s) / ∂X_j`` per state unit (m, m/s, A·m²). Analytic
        (∂B/∂x = −G, ∂G/∂x = −T the third-order tensor; the baseline's differences of ∂B/∂x);
        the velocity columns are 0 at one instant.

    Examples
    --------
    >>> import core
    >>> h, J = core.magnetic_jacobian([1, 2, 3, 1, 0, 10, -20, 30], [[0, 0, 0]], sensor="BG")
    >>> h.shape, J.shape
    ((1, 8), (1, 8, 8))
    """
    return measurement_rows(states, stations, sensor, baseline, 0.0)


def measurement_rows(states_value, stations_value, sensor, baseline, dt):
    """Validated :func:`core.kernels.gamma.magnetic_rows` at time offset ``dt`` (s·T): the rows
    of the map kernels, unwhitened."""
    if sensor not in MAGNETIC_COMPONENTS:
        raise ValueError(f"magnetic sensor kind must be one of {list(MAGNETIC_COMPONENTS)}; got {sensor!r}")
    baseline = baseline_value(baseline)
    flat, lead, stations, _ = _checked(states_value, stations_value, baseline * ("G" in sensor), dt)
    n_s, n_c = stations.shape[0], len(MAGNETIC_COMPONENTS[sensor])
    h = np.empty((flat.shape[0], n_s, n_c))
    jac = np.empty((flat.shape[0], n_s, n_c, mk.N_STATE))
    code = MAGNETIC_CODES[sensor]
    params = np.array([validation.ON_STATION, baseline, 1.0, 1.0])
    if flat.shape[0] > mk.BLOCK:
        gk.magnetic_rows(flat, stations, float(dt), code, params, h, jac)
    else:  # one block: on this thread
        gk.magnetic_rows_block(flat, stations, float(dt), code, params, h, jac, 0, flat.shape[0])
    return h.reshape(lead + (n_s, n_c)), jac.reshape(lead + (n_s, n_c, mk.N_STATE))


def _tensor(name, value):
    arr = validation.as_array(name, value)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have shape (..., 3, 3) (a gradient tensor, nT/m); got shape {arr.shape}")
    validation.finite(name, arr)
    return arr


class TensorInvariants(NamedTuple):
    """Rotation invariants of a gradient tensor (nT/m), each of shape (...)."""

    #: Eigenvalues λ1 ≥ λ2 ≥ λ3, shape (..., 3), nT/m.
    eigenvalues: np.ndarray
    #: I1 = Gxx Gyy + Gyy Gzz + Gxx Gzz − Gxy² − Gyz² − Gxz² = λ1λ2 + λ2λ3 + λ1λ3, (nT/m)².
    i1: np.ndarray
    #: I2 = det G = λ1 λ2 λ3, (nT/m)³.
    i2: np.ndarray
    #: Normalised source strength √(−λ2² − λ1 λ3) = 3 μ0 |m| / (4π r⁴) for a dipole, nT/m.
    nss: np.ndarray


def tensor_invariants(G):
    """Rotation invariants of gradient tensors.

    Parameters
    ----------
    G : array_like, shape (..., 3, 3)
        Gradient tensors (nT/m); the symmetric part is used (a point tensor is symmetric).

    Returns
    -------
    TensorInvariants
        ``eigenvalues`` (..., 3) sorted λ1 ≥ λ2 ≥ λ3; ``i1``, ``i2`` (...); ``nss`` (...), the
        normalised source strength √(−λ2² − λ1λ3), which for a point dipole equals
        k = 300 |m| / r⁴ nT/m whatever the moment's orientation (spec §11).

    Examples
    --------
    >>> import numpy as np, core
    >>> G = core.gradient_tensor([0, 0, 0, 1, 0, 30, -40, 0], [[0, 0, 10]])
    >>> bool(np.isclose(core.tensor_invariants(G).nss[0], 300 * 50 / 10**4))
    True
    """
    g = _tensor("G", G)
    sym = 0.5 * (g + np.swapaxes(g, -1, -2))
    lam = np.linalg.eigvalsh(sym)[..., ::-1]  # (..., 3), descending
    l1, l2, l3 = lam[..., 0], lam[..., 1], lam[..., 2]
    i1 = l1 * l2 + l2 * l3 + l1 * l3
    i2 = l1 * l2 * l3
    with np.errstate(invalid="ignore"):
        nss = np.sqrt(np.maximum(-l2 * l2 - l1 * l3, 0.0))
    return TensorInvariants(eigenvalues=lam, i1=i1, i2=i2, nss=nss)


def euler_locate(B, G):
    """Locate a dipole from one reading by Euler's homogeneity: G·r = −3B, r = −3 G⁻¹ B.

    Parameters
    ----------
    B : array_like, shape (..., 3)
        Field at the sensor (nT), from the dipole alone (background removed).
    G : array_like, shape (..., 3, 3)
        Gradient tensor at the sensor (nT/m).

    Returns
    -------
    r : ndarray, shape (..., 3)
        Sensor − source (m): the source is at ``sensor − r``.

    Raises
    ------
    ValueError
        Wrong shapes, non-finite values, or a singular G (reciprocal condition number below
        :data:`EULER_RCOND`): it is singular on the plane m ⊥ r, where one reading cannot
        locate the source.

    Examples
    --------
    >>> import numpy as np, core
    >>> x = [3, -4, 12, 1, 0, 10, 20, -30]
    >>> B, G = core.magnetic_field(x, [[0, 0, 0]]), core.gradient_tensor(x, [[0, 0, 0]])
    >>> bool(np.allclose(core.euler_locate(B, G), [[-3, 4, -12]]))
    True
    """
    g = _tensor("G", G)
    b = validation.as_array("B", B)
    if b.shape[-1:] != (3,) or b.shape[:-1] != g.shape[:-2]:
        raise ValueError(f"B must have shape (..., 3) matching G's (..., 3, 3) = {g.shape}; got {b.shape}")
    validation.finite("B", b)
    if g.size:
        sv = np.linalg.svd(g, compute_uv=False)
        rcond = sv[..., -1] / np.where(sv[..., 0] > 0, sv[..., 0], 1.0)
        bad = rcond < EULER_RCOND
        if np.any(bad):
            idx = tuple(np.argwhere(bad)[0]) if bad.ndim else ()
            raise ValueError(
                f"G at index {idx} is singular (σmin/σmax = {float(rcond[idx]):.3g} < {EULER_RCOND}): "
                "Euler's formula r = −3 G⁻¹ B cannot locate a source from it (the moment is "
                "perpendicular to the line of sight, or G is zero); use several readings"
            )
    return -3.0 * np.linalg.solve(g, b[..., None])[..., 0]
