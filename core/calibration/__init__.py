"""Calibrating a ship's three-component magnetometer: observability and the Kalman filter of seed 004.

A magnetometer on a ship reads (seed 004, eq. (1); spec §9)

    B = K · A(ψ, θ, φ) · Be + Bp                                  (nT)

with Be the geomagnetic field in the earth frame (x north, y east, z down, nT), A the rotation
from the earth frame to the ship frame (x bow, y starboard, z keel) by heading ψ, roll θ and
pitch φ (rad), K the 3 × 3 induced-interference matrix (dimensionless) and Bp the
permanent-interference vector (nT). The twelve coefficients (K, Bp) are constant. Each attitude
gives three equations that are *linear* in them, so everything here is exact linear algebra:

- per sensor axis i, ``B_i(n) = C(n) · [k_i1, k_i2, k_i3, Bp_i]ᵀ`` with the 1 × 4 row
  ``C(n) = [Beᵀ Aᵀ(n), 1]`` of seed 004 (its eq. (6)); the three axes share C(n);
- the observability matrix Γ of the 12 coefficients over a manoeuvre (a list of attitudes) is
  ``I₃ ⊗ G`` with G the N × 4 stack of C(n) (in the coefficient order of :data:`COEFFICIENTS`),
  so rank Γ = 3 · rank G. G has full rank 4 exactly when the ship-frame field vectors
  ``A(n) Be`` are not coplanar: level headings keep them on one horizontal plane (the
  four-heading method's blind spot: K's third column and Bp cannot be told apart), and so does a
  constant heel; a roll or pitch that *varies* between attitudes tilts them off it.

The attitude convention (:data:`CONVENTIONS`): seed 004 prints A as eq. (2),
``A = R_y(−φ) · R_x(θ) · R_z(ψ)`` with R the standard passive rotations (the matrices are in
:func:`attitude_matrix`'s Notes), but its caption names φ, θ, ψ as heading, roll and pitch,
contradicting its own Table 1 (ψ takes the four heading values 0, π/2, π, 3π/2; θ is the roll of
±0.2 rad; φ the small pitch). The default ``"seed004"`` is eq. (2) with Table 1's names: the
paper's own K and Bp fit Table 1 only with eq. (2)'s sign of the pitch factor (residual RMS
454 nT, against ≥ 837 nT with the standard sign); docs/calibration.md has the comparison.

The package, one concern per module: :mod:`.validation` (checks at the boundary), :mod:`.model`
(A, B, C(n), Γ), :mod:`.observability` (rank, unobservable directions, CRLB), :mod:`.estimators`
(least squares, Kalman filter), :mod:`.geomagnetic` (Be from the readings), :mod:`.manoeuvres`
(attitudes, simulated readings), :mod:`.data` (seed 004's cases, CSV input and its limits),
:mod:`.misfit` (a model that does not fit, said in words) and :mod:`core.cli.calibration` (``python -m
core.calibration``, the only module that imports argparse, and not imported here). Every step
is linear in the number of readings in time and memory. No web stack is imported here.
"""

from __future__ import annotations

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

__all__ = [
    "ANGLE_LIMIT",
    "ANGLE_NOISE_MAX_RAD",
    "BE_RANGE_NT",
    "CAL_RANK_RTOL",
    "COEFFICIENTS",
    "COEFFICIENT_UNITS",
    "CONVENTIONS",
    "CSV_COLUMNS",
    "DEFAULT_P0_DIAG",
    "KALMAN_STEP_BUDGET",
    "MAX_KALMAN_ITERATIONS",
    "MISFIT_RATIO",
    "NOISY_RATIO",
    "MAX_CSV_BYTES",
    "MAX_CSV_ROWS",
    "MAX_LINE_CHARS",
    "MAX_READING_NT",
    "NOISE_RANGE_NT",
    "SEED004_SIMULATION",
    "SEED004_TABLE1",
    "CalibrationObservability",
    "FitDiagnosis",
    "GeomagneticError",
    "KalmanResult",
    "LsqResult",
    "attitude_matrix",
    "calibration_covariance",
    "calibration_crlb",
    "calibration_gamma",
    "calibration_observability",
    "convergence_iteration",
    "default_iterations",
    "design_rows",
    "fit_diagnosis",
    "geomagnetic_error",
    "geomagnetic_solution",
    "heading_manoeuvre",
    "kalman_calibrate",
    "level_headings",
    "lsq_calibrate",
    "parse_attitude_csv",
    "random_attitudes",
    "read_attitude_csv",
    "seed004_table1",
    "seed004_table1_path",
    "ship_field",
    "simulate_ship_data",
]
