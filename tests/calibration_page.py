"""The Calibration tab alone, for ``panel serve`` in tests/test_calibration_browser.py."""

import panel as pn

from app.calibration import calibration_tab
from app.scenario import Scenario

pn.extension(throttled=True, notifications=False)
calibration_tab(Scenario()).servable(title="Calibration tab")
