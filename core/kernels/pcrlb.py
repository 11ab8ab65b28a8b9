"""The compiled Tichavský recursion of the posterior Cramér–Rao bound
(:func:`core.tracking.pcrlb.pcrlb`). A leaf, as every module of :mod:`core.kernels`: numpy and
numba only.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def _recursion(Finv, FinvT, Q, J0, info):
    """J_k for k = 0 … K−1 (K, n, n), n the state size of ``info``: the Tichavský recursion,
    compiled (a Python loop of numpy n × n calls costs ~0.2 ms a step in call overhead alone)."""
    steps = info.shape[0]
    eye = np.eye(info.shape[1])
    out = np.empty_like(info)
    J = J0.copy()
    for k in range(steps):
        if k:
            M = FinvT @ J @ Finv  # information of F X_k without the process noise
            J = np.linalg.solve(eye + M @ Q, M)  # (Q + F J⁻¹ Fᵀ)⁻¹, valid for singular J, Q
        J = J + info[k]
        J = 0.5 * (J + J.T)  # keep it symmetric against round-off
        out[k] = J
    return out
