"""Seed 003: locating and sizing an extended magnetic target from a moving gradiometer.

Truth models (:mod:`.targets`), the N-dipole estimation model (:mod:`.model`), PCA shape
(:mod:`.pca`), the experiment runner (:mod:`.experiment`), the bound (:mod:`.bound`) and the
command line ``python -m core.shape`` (:mod:`core.cli.shape`). Filters: :mod:`core.tracking.unscented`.
"""

from .model import DipoleModel, collapsed, start_state
from .pca import ShapeEstimate, axis_angle_deg, pca_shape
from .targets import Outliers, Pass, Target, attitude_matrix

__all__ = ["DipoleModel", "Outliers", "Pass", "ShapeEstimate", "Target", "attitude_matrix",
           "axis_angle_deg", "collapsed", "pca_shape", "start_state"]
