"""A real sea: insulating air above, seawater, a conducting seabed below (spec §7).

Frame: z is depth, positive down; the sea surface is z = 0 and the seabed z = D. Seawater has
conductivity σ (the ``sigma`` of every public function), the seabed σb ≥ 0, the air none. The
field is a sum of free-space images at depths ε·z0 + 2 m D (ε = ±1, m ∈ ℤ) with weights η^|m|,
η = (σ − σb)/(σ + σb), summed per pair until a tolerance and closed by an integral (η > 0);
the derivation, truncation and tail are in docs/sea.md, the compiled series in
:mod:`core.kernels.sea`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..kernels import gamma as kernels
from . import validation

__all__ = ["DEFAULT_TOL", "Sea", "image_counts"]

#: Default truncation tolerance on the total field (relative).
DEFAULT_TOL = 1e-6


@dataclass(frozen=True)
class Sea:
    """A sea of depth ``depth`` (m) over a seabed of conductivity ``seabed_sigma`` (S/m).

    Parameters
    ----------
    depth : float
        Water depth D (m), finite, > 0. The surface is z = 0, the seabed z = D (z down).
    seabed_sigma : float
        Seabed conductivity σb (S/m), finite, ≥ 0 (0: an insulating seabed).
    tol : float
        Relative truncation tolerance of the image series on the total field, in
        [1e-14, 1e-6] (default 1e-6).

    Examples
    --------
    >>> import core
    >>> sea = core.Sea(8.4, 0.4)
    >>> round(sea.eta(4.0), 4)
    0.8182
    """

    depth: float
    seabed_sigma: float
    tol: float = DEFAULT_TOL

    def __post_init__(self):
        for name, value, ok, accepted in (
            ("depth", self.depth, lambda v: v > 0.0, "a finite number > 0 (m)"),
            ("seabed_sigma", self.seabed_sigma, lambda v: v >= 0.0, "a finite number ≥ 0 (S/m)"),
            ("tol", self.tol, lambda v: 1e-14 <= v <= 1e-6, "a number in [1e-14, 1e-6]"),
        ):
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise ValueError(f"Sea {name} must be {accepted}; got {value!r}") from None
            if not (math.isfinite(v) and ok(v)):
                raise ValueError(f"Sea {name} must be {accepted}; got {value!r}")
            object.__setattr__(self, name, v)

    @classmethod
    def from_resistivity(cls, depth, seabed_resistivity, tol=DEFAULT_TOL):
        """A sea from the seabed resistivity ρb (Ω·m, > 0; ``inf`` for an insulating seabed)."""
        try:
            rho = float(seabed_resistivity)
        except (TypeError, ValueError):
            rho = float("nan")
        if not rho > 0.0:
            raise ValueError(f"seabed_resistivity must be a number > 0 (Ω·m); got {seabed_resistivity!r}")
        return cls(depth, 0.0 if math.isinf(rho) else 1.0 / rho, tol)

    @property
    def seabed_resistivity(self):
        """ρb = 1/σb (Ω·m); inf for an insulating seabed."""
        return math.inf if self.seabed_sigma == 0.0 else 1.0 / self.seabed_sigma

    def eta(self, sigma):
        """Seabed reflection coefficient η = (σ − σb)/(σ + σb) ∈ (−1, 1] for water σ (S/m)."""
        return (sigma - self.seabed_sigma) / (sigma + self.seabed_sigma)


#: The kernels' medium of the whole space (``sea=None``): depth 0 switches the images off.
WHOLE_SPACE = np.zeros(3)


def medium(sea, sigma):
    """Kernel form of a sea: float64 ``[D, η, tol]``; :data:`WHOLE_SPACE` for ``sea=None``."""
    if sea is None:
        return WHOLE_SPACE
    if not isinstance(sea, Sea):
        raise ValueError(f"sea must be None (whole space) or a core.Sea; got {type(sea).__name__}")
    return np.array([sea.depth, sea.eta(sigma), sea.tol])


def check_column(sea, states, stations, model):
    """With a sea, every target (P, 7) and station (S, 3) must be in the water column 0 ≤ z ≤ D,
    and the model must be "exact"."""
    if sea is None:
        return
    if model != "exact":
        raise ValueError(f"model {model!r} has no layered-sea form: the paper's printed formulas "
                         "are not a dipole field, so they have no images; use model='exact' with sea")
    for name, z in (("target depth z", states[:, 2]), ("station depth", stations[:, 2])):
        bad = (z < 0.0) | (z > sea.depth)
        if np.any(bad):
            raise ValueError(f"{name} {float(z[bad][0])!r} m is outside the water column: with "
                             f"sea=Sea(depth={sea.depth!r}) it must lie in [0, {sea.depth!r}] m "
                             "(z is depth, positive down; surface 0, seabed D)")


def image_counts(states, stations, sea, *, sigma=4.0, lanes=1):
    """Number of free-space images (tail nodes included) the series uses per target and station.

    Parameters
    ----------
    states : array_like, shape (..., 7)
    stations : array_like, shape (S, 3)
    sea : core.Sea
    sigma : float
        Sea conductivity (S/m), > 0.
    lanes : int
        1 (default): each pair summed alone, as :func:`core.dipole_field` and every per-point
        function sum it. ``core.kernels.gamma.LANES``: the flattened targets summed ``lanes`` at a time
        in lockstep (a short last run padded with its first target), as the map kernels sum
        them; every pair of a run then shows the run's common count.

    Returns
    -------
    ndarray of int, shape (..., S)
    """
    return _series(states, stations, sea, sigma, lanes)[2]


def _series(states, stations, sea, sigma, lanes):
    """E (..., S, 3), ∂E/∂X (..., S, 3, 7) and image counts (..., S) of the series summed
    ``lanes`` targets at a time (:func:`image_counts`)."""
    states, stations, lead = validation.states_and_stations(states, stations)
    sigma = validation.positive("sigma", sigma, "S/m")
    if not isinstance(sea, Sea):
        raise ValueError(f"sea must be a core.Sea; got {type(sea).__name__}")
    validation.integer("lanes", lanes, 1, kernels.LANES)
    check_column(sea, states, stations, "exact")
    validation.no_target_on_station(states, stations)
    p, n_s = states.shape[0], stations.shape[0]
    e, jac = np.empty((p, n_s, 3)), np.empty((p, n_s, 3, 7))
    counts = np.empty((p, n_s), dtype=np.int64)
    kernels.layered_pairs(states, stations, 1.0 / (4.0 * np.pi * sigma), medium(sea, sigma),
                          int(lanes), e, jac, counts)
    return (e.reshape(lead + (n_s, 3)), jac.reshape(lead + (n_s, 3, 7)),
            counts.reshape(lead + (n_s,)))
