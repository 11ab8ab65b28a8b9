"""Calibrating a ship's three-component magnetometer: observability and the Kalman filter of seed 004.

A magnetometer on a ship reads (seed 004, eq. (1); spec §9)

    B = K · A(ψ, θ, φ) · Be + Bp                                  (nT)

with Be the geomagnetic field in the earth frame (x north, y east, z down, nT), A the rotation
from the earth frame to the ship frame (x bow, y starboard, z keel) by heading ψ, roll θ and
pitch φ (rad), K the 3 × 3 induced-interference matrix (dimensionless) and Bp the
permanent-interference vector (nT). Each attitude gives three equations *linear* in the twelve
coefficients (K, Bp): each sensor axis i reads ``C(n) · [k_i1, k_i2, k_i3, Bp_i]ᵀ`` with seed
004's row ``C(n) = [Beᵀ Aᵀ(n), 1]``, and Γ = I₃ ⊗ G, G the N × 4 stack of C(n), so everything
here is exact linear algebra, linear in the number of readings in time and memory. Why, the
attitude :data:`CONVENTIONS` (the default ``"seed004"`` is eq. (2) with Table 1's angle names)
and the package's modules, one concern each: docs/calibration.md. ``python -m
core.calibration`` is :mod:`core.cli.calibration`, not imported here. No web stack is imported
here.
"""

import inspect as _inspect

from .data import (
    CSV_COLUMNS,
    MAX_CSV_BYTES,
    MAX_CSV_ROWS,
    MAX_LINE_CHARS,
    MAX_READING_NT,
    SEED004_SIMULATION,
    SEED004_TABLE1,
    parse_attitude_csv,
    read_attitude_csv,
    seed004_table1,
    seed004_table1_path,
)
from .estimators import (
    DEFAULT_P0_DIAG,
    KALMAN_STEP_BUDGET,
    MAX_KALMAN_ITERATIONS,
    KalmanResult,
    LsqResult,
    convergence_iteration,
    default_iterations,
    kalman_calibrate,
    lsq_calibrate,
)
from .geomagnetic import GeomagneticError, geomagnetic_error, geomagnetic_solution
from .manoeuvres import heading_manoeuvre, level_headings, random_attitudes, simulate_ship_data
from .misfit import MISFIT_RATIO, NOISY_RATIO, FitDiagnosis, fit_diagnosis
from .model import (
    COEFFICIENT_UNITS,
    COEFFICIENTS,
    CONVENTIONS,
    attitude_matrix,
    calibration_gamma,
    design_rows,
    ship_field,
)
from .observability import (
    CAL_RANK_RTOL,
    CalibrationObservability,
    calibration_covariance,
    calibration_crlb,
    calibration_observability,
)
from .validation import ANGLE_LIMIT, ANGLE_NOISE_MAX_RAD, BE_RANGE_NT, NOISE_RANGE_NT

#: Every name imported above (not the modules).
__all__ = sorted(k for k, v in globals().items()
                 if not k.startswith("_") and not _inspect.ismodule(v))
