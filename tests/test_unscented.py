"""core.tracking.unscented: the UKF step against Stone Soup's, the Huber weights, NHUKF(u → ∞) = UKF,
and seed 001's electric cases through the same UKF."""

import numpy as np
import pytest
from stonesoup.base import Property
from stonesoup.models.measurement.nonlinear import NonLinearGaussianMeasurement
from stonesoup.models.transition.linear import LinearGaussianTimeInvariantTransitionModel
from stonesoup.predictor.kalman import UnscentedKalmanPredictor
from stonesoup.types.detection import Detection
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.state import GaussianState, StateVectors
from stonesoup.updater.kalman import UnscentedKalmanUpdater

import core
from core.tracking import unscented as uk
from core.tracking.montecarlo import CASES


class ElectricMeasurement(NonLinearGaussianMeasurement):
    """Stone Soup's view of core.SensorModel: h(X) from the one measurement model."""

    sensors: object = Property(default=None, doc="the core.SensorModel")

    @property
    def ndim_meas(self):
        return self.sensors.n_meas

    def function(self, state, noise=False, **kwargs):
        X = np.asarray(state.state_vector, dtype=float).T  # (points, 7)
        return StateVectors(self.sensors.h(X).T)


def _setup():
    sensors = CASES["seed001-sim"].sensors()
    F, Q = core.dwna_model(1.0, 0.1, 0.001)
    x = np.array([-30.0, 60.0, 0.2, 0.5, -2.0, 100.0, 0.0])
    P = np.diag([9.0, 16.0, 0.04, 0.25, 0.25, 100.0, 4.0])
    P[0, 1] = P[1, 0] = 3.0
    return sensors, F, Q, x, P


@pytest.mark.parametrize("params", [(1.0, 2.0, 0.0), (0.5, 2.0, -4.0), (0.3, 1.0, 1.0)])
def test_ukf_step_equals_stone_soup(params):
    """Predict then update with the same α, β, κ: x and P agree to 1e-10 relative (both are the
    same float64 algebra in a different order; the seed 001 field is ~1e-6 V/m with
    σ = 1e-7 V/m, so S is well conditioned)."""
    alpha, beta, kappa = params
    sensors, F, Q, x, P = _setup()
    truth = x + np.array([2.0, -3.0, 0.1, 0.2, 0.1, 5.0, 1.0])
    z = sensors.h(F @ truth) + 3e-8 * np.arange(sensors.n_meas)

    tm = LinearGaussianTimeInvariantTransitionModel(transition_matrix=F, covariance_matrix=Q)
    mm = ElectricMeasurement(ndim_state=7, mapping=tuple(range(7)), noise_covar=sensors.R,
                             sensors=sensors)
    pred = UnscentedKalmanPredictor(tm, alpha=alpha, beta=beta, kappa=kappa).predict(
        GaussianState(x.reshape(-1, 1), P))
    upd = UnscentedKalmanUpdater(mm, alpha=alpha, beta=beta, kappa=kappa).update(
        SingleHypothesis(pred, Detection(z.reshape(-1, 1), measurement_model=mm)))

    kw = dict(alpha=alpha, beta=beta, kappa=kappa)
    xp, Pp = uk.ukf_predict(x[None], P[None], lambda X: X @ F.T, Q, **kw)
    np.testing.assert_allclose(xp[0], np.ravel(pred.state_vector), rtol=1e-10, atol=0)
    np.testing.assert_allclose(Pp[0], np.asarray(pred.covar), rtol=1e-10, atol=1e-10 * np.abs(Pp).max())
    xu, Pu, nu, S, psi = uk.ukf_update(xp, Pp, z[None], sensors.h, sensors.R, **kw)
    np.testing.assert_allclose(xu[0], np.ravel(upd.state_vector), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(Pu[0], np.asarray(upd.covar), rtol=0,
                               atol=1e-10 * np.abs(np.asarray(upd.covar)).max())
    assert np.all(psi == 1.0)
    assert not np.allclose(xu[0], xp[0], rtol=1e-3)  # the update did move the state


def test_huber_weights_on_a_constructed_residual():
    u = 1.345
    e = np.array([0.0, 1.0, -1.345, 1.3451, -2.69, 10.0, -134.5])
    want = np.array([1, 1, 1, 1.345 / 1.3451, 0.5, 0.1345, 0.01])
    np.testing.assert_allclose(uk.huber_weights(e, u), want, rtol=1e-15)
    assert np.all(uk.huber_weights(e, np.inf) == 1.0)
    with pytest.raises(ValueError, match="u must be > 0"):
        uk.huber_weights(e, 0.0)


def test_huber_update_inflates_only_the_outlying_component():
    """A linear measurement of 2 states (h = identity), R = diag(1, 4): the NHUKF's update equals
    a Kalman update with R̃ = diag(1, 4 · |e₂| / u) when only component 2 is beyond u."""
    x = np.zeros((1, 2))
    P = np.eye(2)[None] * 9.0
    R = np.diag([1.0, 4.0])
    z = np.array([[0.5, 20.0]])  # whitened residuals 0.5 and 10
    xu, Pu, nu, S, psi = uk.ukf_update(x, P, z, lambda X: X, R, u=1.345)
    np.testing.assert_allclose(psi[0], [1.0, 1.345 / 10.0], rtol=1e-14)
    Rt = np.diag([1.0, 4.0 * 10.0 / 1.345])
    K = P[0] @ np.linalg.inv(P[0] + Rt)
    np.testing.assert_allclose(xu[0], K @ z[0], rtol=1e-12)
    np.testing.assert_allclose(Pu[0], P[0] - K @ (P[0] + Rt) @ K.T, rtol=1e-12)
    # the plain UKF takes the full outlier
    xo = uk.ukf_update(x, P, z, lambda X: X, R)[0]
    assert xo[0, 1] > 2 * xu[0, 1]


def test_nhukf_with_infinite_threshold_is_the_ukf():
    sensors, F, Q, x, P = _setup()
    rng = np.random.default_rng(1)
    truth = core.straight_track(x[:3], -np.pi / 2, 2.0, 20, Ph=100.0)
    zs = sensors.h(truth)[None] + sensors.noise * rng.standard_normal((1, 20, sensors.n_meas))
    fx = lambda X: X @ F.T
    hx = lambda X, k: sensors.h(X)
    a = uk.run_ukf(x[None], P, zs, hx, sensors.R, fx=fx, Q=Q, u=np.inf)
    b = uk.run_ukf(x[None], P, zs, hx, sensors.R, fx=fx, Q=Q, u=1e300)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.P, b.P)
    c = uk.run_ukf(x[None], P, zs, hx, sensors.R, fx=fx, Q=Q, u=1.345)
    assert np.any(c.psi < 1) and not np.array_equal(a.x, c.x)  # a finite u does act


@pytest.mark.parametrize("case_name", ["seed001-sim", "seed001-trial"])
def test_seed001_cases_run_through_the_same_ukf(case_name):
    """Seed 001's electric cases (core.track's cases, core.SensorModel's h) through the UKF:
    over 10 runs from the EKF's prior the final RMS position error is within 1.5 × (+ 5 cm) that
    of the EKF on the same data (the two filters see the same measurements), and both
    track (final error < 2 m, from a 20 m prior)."""
    case = CASES[case_name]
    sensors = case.sensors()
    F, Q = core.dwna_model(case.T, case.sigma_a, case.alpha)
    steps = 150
    truth = case.nominal_track()[:steps]
    rng = np.random.default_rng(7)
    n = 10
    x0 = truth[0] + np.asarray(case.prior_std) * rng.standard_normal((n, 7))
    lo, hi = sensors.depth_range
    x0[:, 2] = np.clip(x0[:, 2], lo + 1e-3, hi - 1e-3)
    zs = sensors.h(truth)[None] + case.noise * rng.standard_normal((n, steps, sensors.n_meas))
    P0 = case.prior_cov()
    ukf = uk.run_ukf(x0, P0, zs, uk.sensor_hx(sensors), sensors.R, fx=lambda X: X @ F.T, Q=Q,
                     truth=np.broadcast_to(truth, (n, steps, 7)))
    ekf = core.run_filters(x0, P0, zs, sensors, F, Q)
    err_u = np.linalg.norm(ukf.x[:, -1, :3] - truth[-1, :3], axis=-1)
    err_e = np.linalg.norm(ekf.x[:, -1, :3] - truth[-1, :3], axis=-1)
    rms_u, rms_e = np.sqrt(np.mean(err_u**2)), np.sqrt(np.mean(err_e**2))
    assert rms_u < 2.0 and rms_e < 2.0, (rms_u, rms_e)
    assert rms_u < 1.5 * rms_e + 0.05, (rms_u, rms_e)  # measured 0.46 / 0.46 m, 0.18 / 0.14 m
