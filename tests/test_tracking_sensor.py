"""One measurement model through tracking and sweeps (issue 26): the EKF, the PCRLB, the
Monte-Carlo driver and ``core.sweep`` take ``sensor=`` (a :class:`core.Sensor` or a kind name);
the magnetic kinds run through the same filters as the electric one.

References independent of the code under test: the batch Fisher information of
core.observability (Γᵀ R⁻¹ Γ stacked over the instants, not the PCRLB recursion), evaluate_map's
compiled/numpy map path (not the sweep's per-cell fronts), chi-square bounds from scipy.
"""

import csv

import numpy as np
import pytest
from scipy import stats

import core
from core import sweep
from core.cli import sweep as sweep_cli
from core.tracking import montecarlo as tr

ORIGIN = [[0.0, 0.0, 0.0]]
MOMENT = (2e3, -1e3, 3e3)  # A·m²


def _magnetic_track(steps, start=(-30.0, 12.0, 8.0)):
    # passes 14 m from the station at 2 m/s: a strong field (B ~ 100 nT) against 0.1 nT noise
    return core.straight_track(start, 0.0, 2.0, steps, moments=MOMENT)


# ------------------------------------------------------------------------------------------
# the one Sensor inside the tracking model
# ------------------------------------------------------------------------------------------

def test_sensor_model_built_from_a_sensor_or_from_the_old_keywords():
    s = core.Sensor("BG", noise=(0.1, 0.02), baseline=0.5)
    a = core.SensorModel(ORIGIN, sensor=s)
    b = core.SensorModel(ORIGIN, kind="BG", noise=(0.1, 0.02), baseline=0.5)
    assert a.sensor == b.sensor == s
    assert (a.kind, a.noise, a.baseline, a.n_states, a.n_meas) == ("BG", (0.1, 0.02), 0.5, 8, 8)
    e = core.SensorModel(ORIGIN, noise=1e-6, sigma=2.0)
    assert e.sensor == core.Sensor("E", 1e-6, 2.0) and e.noise == 1e-6 and e.n_states == 7
    assert core.SensorModel(ORIGIN).noise == core.DEFAULT_NOISE  # the electric default, as before
    assert core.SensorModel(ORIGIN, sensor="G").sensor == core.Sensor("G")
    with pytest.raises(ValueError, match="not both"):
        core.SensorModel(ORIGIN, sensor="B", noise=0.1)
    with pytest.raises(ValueError, match="not both"):
        core.SensorModel(ORIGIN, sensor=core.Sensor("E"), sigma=2.0)


def test_h_and_jacobian_come_from_the_sensor():
    x = _magnetic_track(3)
    for sensor in (core.Sensor("B"), core.Sensor("G", baseline=0.5), core.Sensor("BG")):
        m = core.SensorModel([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]], sensor=sensor)
        h, J = m.h_and_jacobian(x)
        h_ref, J_ref = sensor.measure(x, m.stations)
        np.testing.assert_array_equal(h, h_ref.reshape(3, -1))
        np.testing.assert_array_equal(J, J_ref.reshape(3, -1, 8))
    # electric: Sensor.measure's h (from the moment columns) is the field itself
    xe = core.straight_track([-30.0, 12.0, 8.0], 0.3, 2.0, 3, Ph=100.0, Pv=20.0)
    h, J = core.Sensor("E").measure(xe, ORIGIN)
    E = core.dipole_field(xe, ORIGIN)
    np.testing.assert_allclose(h, E, rtol=1e-13, atol=1e-13 * np.abs(E).max())
    np.testing.assert_array_equal(J, core.field_jacobian(xe, ORIGIN))


def test_tracking_functions_take_stations_and_sensor():
    track = _magnetic_track(30)
    sensor = core.Sensor("BG", noise=(0.1, 0.1))
    a = core.pcrlb(track, ORIGIN, sensor=sensor)
    b = core.pcrlb(track, core.SensorModel(ORIGIN, sensor=sensor))
    np.testing.assert_array_equal(a.information, b.information)
    e1 = core.pcrlb(_electric_track(), [[0.0, -10.0, 20.0], [0.0, 10.0, 20.0]])  # sensor None: E
    e2 = core.pcrlb(_electric_track(), core.SensorModel([[0.0, -10.0, 20.0], [0.0, 10.0, 20.0]]))
    np.testing.assert_array_equal(e1.information, e2.information)
    with pytest.raises(ValueError, match="carries its own Sensor"):
        core.pcrlb(track, core.SensorModel(ORIGIN, sensor="B"), sensor="BG")
    with pytest.raises(ValueError, match=r"shape \(steps, 8\)"):
        core.pcrlb(_electric_track(), ORIGIN, sensor="B")  # 7 states for a magnetic kind
    F, Q = core.dwna_model(n_states=8)
    with pytest.raises(ValueError, match=r"x0 must have shape \(N, 8\)"):
        core.run_filters(np.zeros((1, 7)), np.eye(7), np.zeros((1, 2, 8)), ORIGIN, F, Q, sensor="BG")
    with pytest.raises(ValueError, match=r"ys must have shape \(R, K, 8\)"):
        core.run_bank(np.zeros((1, 2, 3)), core.SensorModel(ORIGIN, sensor="BG"), F, Q, depth=1.0)


def _electric_track():
    return core.straight_track([-40.0, -30.0, 5.0], 0.6, 1.0, 20, Ph=100.0, Pv=20.0)


# ------------------------------------------------------------------------------------------
# PCRLB of a magnetic sensor = the inverse of core's stacked Fisher information
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("sensor, stations", [
    (core.Sensor("BG", noise=(0.05, 0.02)), ORIGIN),
    (core.Sensor("G", noise=0.02, baseline=0.5), [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]]),
])
def test_pcrlb_of_a_static_magnetic_target_is_the_inverse_stacked_fisher(sensor, stations):
    # A static target (v = 0) and no process noise: nothing moves, so the information after
    # k + 1 readings is Σ_i Φ^iᵀ Hᵀ R⁻¹ H Φ^i = core.fisher_information over k + 1 instants,
    # computed from Γ by core's Fisher (all rows, whitened by the noise of each component).
    x0 = np.array([6.0, -4.0, 9.0, 0.0, 0.0, *MOMENT])
    steps = 12
    track = np.repeat(x0[None], steps, axis=0)
    b = core.pcrlb(track, stations, sensor=sensor, sigma_a=0.0, alpha=0.0)
    F, _ = core.dwna_model(1.0, 0.0, 0.0, n_states=8)
    for k in (1, 4, steps - 1):
        fisher = core.fisher_information(x0, stations, steps=k + 1, sensor=sensor)
        Fk = np.linalg.matrix_power(F, k)
        # information about x_k = F^k x_0: F^-kᵀ I_0 F^-k
        Fi = np.linalg.inv(Fk)
        np.testing.assert_allclose(b.information[k], Fi.T @ fisher @ Fi, rtol=1e-10,
                                   atol=1e-12 * np.abs(b.information[k]).max())
        np.testing.assert_allclose(b.cov[k], Fk @ np.linalg.inv(fisher) @ Fk.T, rtol=1e-6,
                                   atol=1e-9 * np.abs(b.cov[k]).max())
        assert b.observable[k]
    # and its position σ is core's batch CRLB of the same instants (velocity known to be 0 here
    # only through the data: the bound is over all 8 states)
    crlb = core.fisher_measures(x0, stations, steps=steps, sensor=sensor).position_std
    np.testing.assert_allclose(b.position_std[-1], crlb, rtol=1e-6)


# ------------------------------------------------------------------------------------------
# the EKF on a magnetic track: consistent NEES over a small Monte Carlo
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("sensor, stations", [
    (core.Sensor("BG", noise=(0.2, 0.02)), ORIGIN),  # unequal noise: R is diagonal, not σ² I
    (core.Sensor("G", noise=0.1, baseline=0.5), [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]),
])
def test_ekf_on_a_magnetic_track_is_consistent(sensor, stations):
    runs, steps = 60, 30
    sensors = core.SensorModel(stations, sensor=sensor)
    sigma_a, alpha = 0.002, 1.0
    F, Q = core.dwna_model(1.0, sigma_a, alpha, n_states=8)
    P0 = np.diag([0.3, 0.3, 0.3, 0.05, 0.05, 20.0, 20.0, 20.0]) ** 2
    rng = np.random.default_rng(11)
    x_hat0 = _magnetic_track(1)[0]
    start = x_hat0 + rng.standard_normal((runs, 8)) * np.sqrt(np.diag(P0))
    truth = core.sample_tracks(start, F, Q, steps, rng)
    ys = sensors.h(truth) + sensors.noise_vector * rng.standard_normal((runs, steps, sensors.n_meas))
    res = core.run_filters(np.repeat(x_hat0[None], runs, 0), P0, ys, sensors, F, Q, truth=truth)
    assert res.alive.all() and res.x.shape == (runs, steps, 8)
    # consistency: the run-mean NEES inside the two-sided 99 % chi-square band of 8·runs dof
    lo, hi = stats.chi2.ppf([0.005, 0.995], 8 * runs) / runs
    mean_nees = res.nees.mean(axis=0)
    inside = (mean_nees > lo) & (mean_nees < hi)
    assert inside.mean() >= 0.9, (lo, hi, mean_nees)
    # and efficient: the RMS position error follows the PCRLB (same truths, same prior)
    bound = core.pcrlb(truth, sensors, sigma_a=sigma_a, alpha=alpha, prior_cov=P0).position_std
    err = np.sqrt(((res.x[..., :3] - truth[..., :3]) ** 2).sum(-1).mean(0))
    ratio = err[steps // 2:] / bound[steps // 2:]
    assert np.all((ratio > 0.6) & (ratio < 1.6)), ratio


def test_monte_carlo_takes_a_magnetic_sensor():
    case = tr.TrackCase(name="bg-pass", stations=tuple(map(tuple, ORIGIN)), axes=3,
                        start=(-30.0, 12.0, 8.0), heading=0.0, speed=2.0, steps=25,
                        sigma_a=0.002, alpha=1.0, moments=MOMENT,
                        prior_std=(0.3, 0.3, 0.3, 0.05, 0.05, 20.0, 20.0, 20.0))
    res = tr.monte_carlo(case, filter="ekf", runs=8, seed=3, sensor=core.Sensor("BG", (0.1, 0.1)))
    assert res.summary["nees_dof"] == 8 and res.error_m.shape == (8, 25)
    assert np.all(np.isfinite(res.pcrlb_m[1:]))
    assert res.trmse_m[-1] < 3.0 * res.pcrlb_m[-1]
    with pytest.raises(ValueError, match="moments"):
        tr.monte_carlo("seed001-sim", filter="ekf", runs=1, sensor="BG")


# ------------------------------------------------------------------------------------------
# sweeps
# ------------------------------------------------------------------------------------------

def _settings(sensor, measure="crlb_position", **kw):
    return dict({"measure": measure, "layout": "line", "stations": 2, "sensor": sensor,
                 "model": "exact", "steps": 3, "sea_depth": None, "seabed_sigma": 1.0,
                 "region": ((-30.0, 30.0), (-30.0, 30.0), 5), "threshold": 1.0}, **kw)


@pytest.mark.parametrize("kind, measure", [("B", "crlb_position"), ("BG", "d_optimal"),
                                           ("E", "crlb_position")])
def test_sweep_with_a_sensor_equals_evaluate_map(kind, measure):
    base = {k: v[0] for k, v in sweep.PARAMETERS.items()}
    base.update(sweep.default_noise(kind), d=10.0, h=0.0, z=12.0)
    if kind == "E":
        base.update(h=100.0, z=120.0)
    xs, ys = np.linspace(-40.0, 40.0, 5), np.linspace(-35.0, 45.0, 5)
    values = sweep.run(("x", xs), ("y", ys), _settings(kind, measure), base, workers=1,
                       progress=False)
    state, opts = sweep.scenario(base, _settings(kind))
    plane = core.Plane("xy", (-40.0, 40.0), (-35.0, 45.0), base["z"], 5)
    stations = core.station_layout("line", 2, d=10.0, h=base["h"])
    ref = core.evaluate_map(plane, stations, velocity=state[3:5], moments=state[5:],
                            measure=measure, steps=3, sensor=opts["sensor"])
    np.testing.assert_allclose(values, ref.value, rtol=1e-9)
    assert np.isfinite(values).all()


def test_sweep_refuses_what_the_kind_does_not_have():
    base = {k: v[0] for k, v in sweep.PARAMETERS.items()}
    with pytest.raises(ValueError, match="electric"):
        sweep.evaluate(base, _settings("B", measure="log10_det"))
    with pytest.raises(ValueError, match="magnetic"):
        sweep.evaluate(base, _settings("BG", sea_depth=200.0))


def test_sweep_cli_with_sensor(tmp_path):
    out = tmp_path / "bg"
    code = sweep_cli.main(["--x", "d=2,5,10", "--y", "mz=100,1000", "--sensor", "BG", "--measure",
                       "crlb_position", "--set", "h=0", "--set", "z=10", "--set", "x=10",
                       "--set", "y=5", "--workers", "1", "--no-progress", "--out", str(out)])
    assert code == 0
    with open(out / "sweep.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["d", "mz", "crlb_position"] and len(rows) == 7
    vals = np.array([float(r[2]) for r in rows[1:]])
    assert np.isfinite(vals).all() and (vals > 0).all()
    # the first cell equals the library's point CRLB of the same Sensor
    x = np.array([10.0, 5.0, 10.0, *core.velocity_from_heading(2.0 * np.sqrt(2.0), 45.0),
                  1e3, -2e3, 100.0])
    st = core.station_layout("line", 2, d=2.0, h=0.0)
    ref = core.horizontal_error_ellipse(x, st, steps=3, sensor=core.Sensor("BG")).position
    np.testing.assert_allclose(vals[0], ref, rtol=1e-12)
    with pytest.raises(SystemExit):
        sweep_cli.main(["--x", "Ph=1,2", "--y", "z=5,10", "--sensor", "B", "--out", str(out)])


def test_the_track_tab_tracks_with_the_scenarios_magnetic_sensor():
    """The Track tab's case is the sidebar's sensor (issue 26 item 5): a magnetic kind gives an
    8-state case with the scenario's moment and core.Sensor, its PCRLB and map from the same
    model; seed 001's bank runs on it too (issue 36)."""
    from app.state.scenario import Scenario
    from app.tabs.track import track

    s = Scenario()
    s.update(sensor="magnetometer + gradiometer (BG)", track_filter="ekf", track_runs=2,
                   track_duration=20.0)
    case = track.case_of(s.snapshot())
    assert case.sensor.kind == "BG" and case.moments == (s.target.mx, s.target.my, s.target.mz)
    assert case.sensors().n_states == 8 and len(case.prior_std) == 8
    out = track.compute(s)
    assert out["res"].summary["nees_dof"] == 8 and out["truth"].shape[1] == 8
    direct = tr.monte_carlo(case, filter="ekf", runs=2, seed=0, workers=1)
    np.testing.assert_allclose(out["res"].pcrlb_m, direct.pcrlb_m, rtol=1e-12)
    assert "(8 states: 8 if consistent)" in track.summary_text(out)
    # issue 40 defect 9: a magnetometer with the bank tracker ran nothing ("Computing the track"
    # for good); issue 36: the bank runs on the magnetic kinds, its levels about |m|
    s.track.track_filter = "bank"
    assert track.tracker_of(s.snapshot()) == ("bank", "")
    out = track.compute(s)
    summary = out["res"].summary
    assert summary["filter"] == "bank" and summary["nees_dof"] == 8
    m = np.linalg.norm(case.moments)
    assert track.case_of(s.snapshot()).bank_strengths == (0.5 * m, m, 2.0 * m)
    assert sum(summary["winners"].values()) == 2


# ------------------------------------------------------------------------------------------
# seed 001's bank, the command line and Dask with a magnetic sensor (issue 36 item 3)
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["B", "G", "BG"])
def test_start_range_inverts_the_magnetic_field_magnitude(kind):
    # noise-free, exactly on a hypothesis (vertical moment p, bearing π/4, inbound): the bank's
    # bisection on ‖h‖ must give back the range (the field is monotonic in r along the bearing)
    stations = [[0.0, -5.0, 8.4], [0.0, 5.0, 8.4]]
    p, r = 1e5, np.hypot(150.0, 150.0)
    sensors = core.SensorModel(stations, sensor=core.Sensor(kind, (1e-12, 1e-12) if kind == "BG"
                                                              else 1e-12))
    x = core.straight_track([150.0, 150.0, 0.2], 5 * np.pi / 4, 2.0, 1, moments=(0.0, 0.0, p))[0]
    y0 = sensors.h(x)[None]
    got = core.start_range(y0, sensors, [p], [np.pi / 4], depth=0.2, speed=2.0, centre=(0.0, 0.0))
    np.testing.assert_allclose(got[0, 0], r, rtol=1e-6)  # 48 bisection steps in log r: ~1e-13


def test_cli_tracks_seed001_with_a_magnetic_sensor(tmp_path, capsys):
    from core.cli import track as track_cli

    out = tmp_path / "bg"
    assert track_cli.main(["--case", "seed001-sim", "--sensor", "BG", "--filter", "ekf",
                           "--runs", "4", "--seed", "1", "--out", str(out)]) == 0
    import json

    summary = json.loads((out / "summary.json").read_text())
    assert summary["case"] == "seed001-sim-BG" and summary["nees_dof"] == 8
    assert summary["diverged"] == 0.0
    # 4 runs from a prior about the truth: the final RMS error near the PCRLB (4 runs: the RMS
    # of 3-D errors scatters by ~±40 % about its mean, so a factor 2.5 either way)
    assert 0.4 < summary["trmse_final_m"] / summary["pcrlb_final_m"] < 2.5
    with (out / "trmse.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 300 and all(np.isfinite(float(r["pcrlb_m"])) for r in rows[1:])


def test_bank_runs_on_a_magnetic_sensor_and_finds_the_bearing():
    case = tr.case_for_sensor("seed001-sim", "BG")
    res = tr.monte_carlo(case, filter="bank", runs=3, seed=2)
    s = res.summary
    assert s["nees_dof"] == 8 and sum(s["winners"].values()) == 3
    assert s["nearest_hypothesis"].endswith("ψ=5π/4")  # the true start bearing
    assert s["nearest_bearing_wins"] == 1.0  # the bank's winner has the right bearing every run
    assert s["diverged"] == 0.0


def test_magnetic_monte_carlo_on_dask_equals_serial():
    from dask.distributed import Client, LocalCluster

    case = tr.TrackCase(name="bg-pass", stations=tuple(map(tuple, ORIGIN)), axes=3,
                        start=(-30.0, 12.0, 8.0), heading=0.0, speed=2.0, steps=20,
                        sigma_a=0.002, alpha=1.0, moments=MOMENT, sensor=core.Sensor("BG", (0.1, 0.1)),
                        prior_std=(0.3, 0.3, 0.3, 0.05, 0.05, 20.0, 20.0, 20.0))
    a = tr.monte_carlo(case, filter="ekf", runs=4, seed=5, workers=1)
    # a real scheduler and two workers in this process, as tests/test_track.py's electric test
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0") as lc:
        with Client(lc) as client:
            b = tr.monte_carlo(case, filter="ekf", runs=4, seed=5, scheduler=lc.scheduler_address)
            assert len(client.scheduler_info()["workers"]) == 2
    np.testing.assert_array_equal(a.error_m, b.error_m)
    assert b.summary["workers"] == "dask" and b.summary["nees_dof"] == 8
