"""Observability of underwater electric-dipole tracking: fields, Γ, measures and maps.

The public API of the spec (§6) is :func:`gamma`, :func:`log10_abs_det_gamma` and
:func:`observable_rank`; the rest builds on them. No web stack is imported here.
"""

import inspect as _inspect

from . import kernel_cache  # noqa: F401  (first: it refreshes the kernels' cache on import)
from .calibration import (
    CAL_RANK_RTOL,
    COEFFICIENTS,
    CONVENTIONS,
    SEED004_SIMULATION,
    SEED004_TABLE1,
    CalibrationObservability,
    FitDiagnosis,
    GeomagneticError,
    KalmanResult,
    LsqResult,
    attitude_matrix,
    calibration_covariance,
    calibration_crlb,
    calibration_gamma,
    calibration_observability,
    convergence_iteration,
    design_rows,
    fit_diagnosis,
    geomagnetic_error,
    geomagnetic_solution,
    heading_manoeuvre,
    kalman_calibrate,
    level_headings,
    lsq_calibrate,
    parse_attitude_csv,
    random_attitudes,
    read_attitude_csv,
    seed004_table1,
    ship_field,
    simulate_ship_data,
)
from .model.fields import MODELS, STATE_UNITS, dipole_field, field_jacobian
from .model.magnetic import (
    MAGNETIC_STATE_NAMES,
    MAGNETIC_STATE_UNITS,
    TensorInvariants,
    euler_locate,
    gradient_tensor,
    magnetic_field,
    magnetic_jacobian,
    tensor_invariants,
)
from .model.measurement import AXES, SensorModel
from .model.sea import Sea
from .model.sensors import KINDS, MAGNETIC_NOISE, Sensor
from .model.validation import STATE_NAMES
from .observability.crlb import CrlbErrors, crlb_covariance, crlb_maps, horizontal_error_ellipse
from .observability.design import (
    CRITERIA,
    CriterionResult,
    LayoutConstraints,
    LayoutProblem,
    LayoutResult,
    SpacingResult,
    StationCount,
    StationLoss,
    best_spacing,
    layout_criterion,
    optimise_layout,
    spacing_curve,
    station_count_curve,
    station_loss,
)
from .observability.fisher import (
    DEFAULT_NOISE,
    DEFAULT_STEPS,
    FisherMeasures,
    fisher_information,
    fisher_measures,
)
from .observability.gamma import (
    RANK_RTOL,
    gamma,
    log10_abs_det_gamma,
    observability_index,
    observable_rank,
    unobservable_direction,
)
from .observability.grids import (
    MAX_RESOLUTION,
    Plane,
    dual_station,
    single_station,
    velocity_from_heading,
)
from .observability.layouts import LAYOUTS, MAX_STATIONS, station_layout
from .observability.maps import (
    MEASURES,
    MapResult,
    evaluate_map,
    log10_positive_difference,
    log10_ratio,
)
from .tracking.bank import (
    BANK_BEARINGS,
    BANK_STRENGTHS,
    SEED_BEARINGS,
    BankResult,
    bank_hypotheses,
    run_bank,
    start_range,
)
from .tracking.filters import FilterRun, ekf_predict, ekf_update, run_filters
from .tracking.motion import dwna_model, sample_tracks, straight_track
from .tracking.pcrlb import PcrlbResult, linearisation_breaks, pcrlb
from .tracking.unscented import (
    UkfRun,
    huber_weights,
    run_ukf,
    sigma_points,
    ukf_predict,
    ukf_update,
)

#: The public API: every name imported above (not the subpackages).
__all__ = sorted(k for k, v in globals().items()
                 if not k.startswith("_") and not _inspect.ismodule(v))
