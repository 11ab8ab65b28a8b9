"""Sensor-layout design: how good a station layout is for a surveillance region, and the best one.

- :func:`layout_criterion` — a layout's region criterion (:data:`CRITERIA`: mean or worst
  D-optimal measure, or the area whose CRLB position error is below a threshold).
- :func:`spacing_curve`, :func:`best_spacing` — the criterion against a scaled layout's
  spacing d, and the best d.
- :func:`optimise_layout` — the best N-station layout of a kind (its spacing, or free positions),
  under the constraints of :class:`LayoutConstraints`.
- :func:`station_loss` — the CRLB when any one station is lost; :func:`station_count_curve` —
  the best criterion for N = 1 … 8 stations and its knee.

These build on :mod:`.crlb` (CRLB covariance, error ellipses and their maps) and :mod:`.layouts`
(:func:`station_layout`), whose public names are re-exported here: ``core.observability.design``
still offers the whole design API.

The criteria live in :mod:`.criteria` (how unobservable points count: its notes), the spacing
search in :mod:`.spacing`, the optimiser in :mod:`.optimiser`; this module gathers them.
"""

import inspect as _inspect

from .constraints import LayoutConstraints
from .criteria import CRITERIA, CriterionResult, layout_criterion
from .crlb import CrlbErrors, crlb_covariance, crlb_maps, horizontal_error_ellipse
from .layouts import LAYOUTS, MAX_STATIONS, station_layout
from .optimiser import LayoutResult, optimise_layout
from .problem import LayoutProblem
from .spacing import SpacingResult, best_spacing, spacing_curve
from .survey import StationCount, StationLoss, station_count_curve, station_loss

#: Every name imported above (not the modules).
__all__ = sorted(k for k, v in globals().items()
                 if not k.startswith("_") and not _inspect.ismodule(v))
