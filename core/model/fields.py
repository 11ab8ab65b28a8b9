"""Electric field of a moving current dipole at a sensor station, and its Jacobian: the
validated public front of the compiled electric kernels (:mod:`core.kernels.electric`, whose
notes give the field models ``exact`` and ``paper``) in the whole space or a layered sea
(:mod:`core.model.sea`).
"""

from __future__ import annotations

import numpy as np

from ..kernels import gamma as kernels
from ..kernels.electric import N_COMPONENTS, N_STATES
from . import sea as sea_module
from . import validation

__all__ = ["MODELS", "STATE_UNITS", "dipole_field", "field_jacobian"]

#: State units, in the same order.
STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "A·m", "A·m")

#: Accepted field-model names; the index is the kernels' model code.
MODELS = ("exact", "paper")


def _field_and_jacobian(states, stations, sigma, model, sea):
    """Validated front end: returns E (..., S, 3) and ∂E/∂X (..., S, 3, 7) (N_COMPONENTS,
    N_STATES of :mod:`core.kernels.electric`)."""
    states, stations, lead = validation.states_and_stations(states, stations)
    sigma = validation.positive("sigma", sigma, "S/m")
    code = validation.model_code(model, MODELS)
    medium = sea_module.medium(sea, sigma)
    sea_module.check_column(sea, states, stations, model)
    validation.no_target_on_station(states, stations)
    n_s = stations.shape[0]
    e = np.empty((states.shape[0], n_s, N_COMPONENTS))
    jac = np.empty((states.shape[0], n_s, N_COMPONENTS, N_STATES))
    kernels.field_and_jacobian(states, stations, 1.0 / (4.0 * np.pi * sigma), code, medium, e, jac)
    return e.reshape(lead + (n_s, N_COMPONENTS)), jac.reshape(lead + (n_s, N_COMPONENTS, N_STATES))


def dipole_field(states, stations, *, sigma=4.0, model="exact", sea=None):
    """Static electric field of the target dipole at each station.

    Parameters
    ----------
    states : array_like, shape (..., 7)
        ``[x, y, z, vx, vy, Ph, Pv]``: target position (m), horizontal velocity (m/s; the
        horizontal moment points along the heading θ = atan2(vy, vx), so speed must be > 0),
        horizontal and vertical dipole moments (A·m).
    stations : array_like, shape (S, 3)
        Station positions (m), S ≥ 1.
    sigma : float
        Sea conductivity (S/m), > 0.
    model : {"exact", "paper"}
        ``"exact"``: point current dipole in a homogeneous conductor. ``"paper"``: the source
        paper's eqs. (10)–(12) as printed (not the field of any dipole; see module notes).
    sea : core.Sea or None
        ``None``: the homogeneous whole space. A :class:`core.Sea`: air / seawater / seabed
        (spec §7), z is depth (surface 0, seabed D) and targets and stations must lie in
        0 ≤ z ≤ D; the field is the image series of :mod:`core.sea`. Only ``model="exact"``.

    Returns
    -------
    E : ndarray, shape (..., S, 3)
        ``(Ex, Ey, Ez)`` in V/m at every station.

    Raises
    ------
    ValueError
        Wrong shapes, non-finite values, zero speed, σ ≤ 0, unknown model, or a target at a
        station (D = 0, where the field is singular); with a sea, a target or station outside
        the water column, or ``model="paper"``.

    Examples
    --------
    On the dipole axis the exact field is ``2 p / (4 π σ D³)``:

    >>> import numpy as np, core
    >>> E = core.dipole_field([0, 0, 0, 1, 0, 100, 0], [[10, 0, 0]], sigma=1.0)
    >>> bool(np.isclose(E[0, 0], 2 * 100 / (4 * np.pi * 1000)))
    True
    """
    return _field_and_jacobian(states, stations, sigma, model, sea)[0]


def field_jacobian(states, stations, *, sigma=4.0, model="exact", sea=None):
    """Exact Jacobian ∂E/∂X of the station fields with respect to the 7 states.

    Parameters are those of :func:`dipole_field`.

    Returns
    -------
    J : ndarray, shape (..., S, 3, 7)
        ``J[..., s, i, j] = ∂E_i(station s) / ∂X_j`` in (V/m) per state unit
        (m, m/s, A·m). Analytic: the quotient rule on the term table plus the heading chain
        ``∂θ/∂vx = −sin θ/|v|, ∂θ/∂vy = cos θ/|v|``.

    Examples
    --------
    >>> import core
    >>> core.field_jacobian([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]]).shape
    (1, 3, 7)
    """
    return _field_and_jacobian(states, stations, sigma, model, sea)[1]
