"""A page holding only the Track tab (app/track.py), served by tests/test_track_browser.py.

The dashboard mounts the tab itself; this page lets the tab be tested on its own."""

from app.scenario import Scenario
from app.track import track_tab

track_tab(Scenario()).servable(title="Track tab")
