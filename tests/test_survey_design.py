"""Survey design (issue 49, spec §13): constraints on a layout problem, the criteria, the loss of
a station and how many stations are enough."""

import numpy as np
import pytest

import core

REGION = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 11)
SQUARE = [(0, 0), (10, 0), (10, 10), (0, 10)]


def _free(n, **constraints):
    problem = core.LayoutProblem(REGION, constraints=core.LayoutConstraints(**constraints))
    return core.optimise_layout("free", n, problem)


@pytest.mark.parametrize("call,message", [
    (lambda: core.LayoutConstraints(zones=[SQUARE, [(0, 0), (1, 1)]]),
     "forbidden zone 1 has 2 vertices; a polygon needs at least 3"),
    (lambda: core.LayoutConstraints(zones=[[(0, 0), (10, 10), (10, 0), (0, 10)]]),
     "forbidden zone 0 is self-intersecting: its edges 0 and 2 cross"),
    (lambda: _free(2, fixed=[[50, 50, 100], [5, 5, 100]], zones=[SQUARE]),
     r"fixed station 1 at \(5, 5\) m lies inside forbidden zone 0"),
    (lambda: _free(2, fixed=[[5, 5, 50]], depth_band=(80, 120)),
     r"fixed station 0 at depth 50 m is outside the allowed depth band \[80, 120\] m"),
    (lambda: _free(2, fixed=[[5, 5, 100], [10, 5, 100]], min_spacing=20),
     "fixed stations 0 and 1 are 5 m apart: they already break the minimum spacing 20 m"),
    (lambda: _free(7, fixed=[[5, 5, 100], [100, 5, 100]]),
     "2 fixed [+] 7 new = 9 stations; at most MAX_STATIONS = 8"),
    (lambda: _free(3, zones=[[(-400, -400), (400, -400), (400, 400), (-400, 400)]]),
     "the constraints leave room for 0 of the 3 new stations"),
    (lambda: _free(8, min_spacing=400), "the constraints leave room for 4 of the 8 new stations"),
    (lambda: _free(2, depth_band="seabed"), "depth_band 'seabed' needs a layered sea"),
    (lambda: core.optimise_layout("free", 2, core.LayoutProblem(
        REGION, constraints=core.LayoutConstraints(depth_band=(0, 50)))),
     r"the new stations' depth h = 100 m is outside the allowed depth band \[0, 50\] m"),
    (lambda: core.optimise_layout("free", 1, core.LayoutProblem(REGION, constraints="none")),
     "constraints must be None or a core.LayoutConstraints"),
])
def test_bad_constraints_are_said_at_once_naming_the_station_or_zone(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_fixed_stations_stay_and_new_ones_avoid_the_zones():
    zone = [(-300, -300), (300, -300), (300, 0), (-300, 0)]  # the whole south half
    fixed = [[-150, 150, 100.0]]
    r = _free(2, fixed=fixed, zones=[zone], min_spacing=30.0)
    assert r.fixed == 1 and r.stations.shape == (3, 3)
    np.testing.assert_array_equal(r.stations[:1], fixed)
    assert np.all(r.stations[1:, 1] > 0)  # none in the forbidden half (its edge y = 0 included)
    d = np.linalg.norm(r.stations[:, None] - r.stations[None], axis=-1)
    assert d[np.triu_indices(3, 1)].min() >= 30.0
    problem = core.LayoutProblem(REGION, constraints=core.LayoutConstraints(
        fixed=fixed, zones=[zone], min_spacing=30.0))
    np.testing.assert_allclose(r.value, core.layout_criterion(r.stations, REGION).value,
                               rtol=0, atol=0)
    assert problem.constraints.violations(r.stations) == []


def test_a_seabed_band_puts_the_new_stations_on_the_seabed():
    sensor = core.Sensor("E", sea=core.Sea(150.0, 1.0))
    region = core.Plane("xy", (-200, 200), (-200, 200), 100.0, 7)
    problem = core.LayoutProblem(region, h=150.0, sensor=sensor, constraints=core.LayoutConstraints(
        fixed=[[0, 0, 150.0]], depth_band="seabed"))
    r = core.optimise_layout("free", 1, problem, maxfev=20)
    assert np.all(r.stations[:, 2] == 150.0)
    with pytest.raises(ValueError, match=r"fixed station 0 at depth 140 m is outside the allowed "
                                         r"depth band \[145, 150\] m"):
        core.optimise_layout("free", 1, core.LayoutProblem(
            region, h=150.0, sensor=sensor, constraints=core.LayoutConstraints(
                fixed=[[0, 0, 140.0]], depth_band=("seabed", 5.0))))
