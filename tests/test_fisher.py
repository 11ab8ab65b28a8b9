"""Fisher information, D-optimal measure and Cramér–Rao bounds."""

import numpy as np
import pytest

import core
from tests.conftest import PAPER_STATE, random_states

DUAL15 = core.dual_station(100, 15)


@pytest.mark.parametrize("model", core.MODELS)
@pytest.mark.parametrize("known", [(), ("Ph", "Pv")])
def test_measures_match_dense_linear_algebra(rng, model, known):
    states = random_states(rng, 30, DUAL15)
    noise = 3e-8
    sensor = core.Sensor("E", noise, model=model)
    m = core.fisher_measures(states, DUAL15, steps=4, known=known, sensor=sensor)
    fisher = core.fisher_information(states, DUAL15, steps=4, known=known, sensor=sensor)
    _, logdet = np.linalg.slogdet(fisher)
    np.testing.assert_allclose(m.d_optimal, 0.5 * logdet / np.log(10), atol=1e-8)
    cov = np.linalg.inv(fisher)
    std = np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1))
    np.testing.assert_allclose(m.std, std, rtol=1e-6)
    np.testing.assert_allclose(m.position_std, np.sqrt(np.sum(std[:, :3] ** 2, axis=1)), rtol=1e-6)
    assert m.free == tuple(n for n in core.STATE_NAMES if n not in known)


def test_crlb_scales_with_noise():
    a = core.fisher_measures(PAPER_STATE, DUAL15, noise=1e-7)
    b = core.fisher_measures(PAPER_STATE, DUAL15, noise=2e-7)
    np.testing.assert_allclose(b.std, 2 * a.std, rtol=1e-12)
    np.testing.assert_allclose(a.d_optimal - b.d_optimal, 7 * np.log10(2), atol=1e-12)


def test_single_station_is_flagged_and_bounds_are_infinite():
    m = core.fisher_measures(PAPER_STATE, core.single_station(100))
    assert not m.observable and m.d_optimal == -np.inf
    assert np.all(np.isinf(m.std)) and np.isinf(m.position_std)
    known = core.fisher_measures(PAPER_STATE, core.single_station(100), known=("Ph", "Pv"))
    assert known.observable and np.all(np.isfinite(known.std))


def test_flag_agrees_with_rank_test(rng):
    for stations in (core.single_station(100), DUAL15):
        states = random_states(rng, 40, stations)
        m = core.fisher_measures(states, stations)
        rank = core.observable_rank(states, stations, steps=core.DEFAULT_STEPS)
        np.testing.assert_array_equal(m.observable, rank == 7)


def test_adding_a_station_never_lowers_d_optimal(rng):
    # F grows by a positive semi-definite term, so det F cannot fall.
    states = random_states(rng, 40, DUAL15)
    third = np.vstack([DUAL15, [[40.0, 30.0, 90.0]]])
    states = states[np.min(np.linalg.norm(states[:, None, :3] - third[None], axis=-1), 1) > 5]
    two = core.fisher_measures(states, DUAL15).d_optimal
    three = core.fisher_measures(states, third).d_optimal
    assert np.all(three >= two - 1e-12)


def test_noise_must_be_positive():
    with pytest.raises(ValueError, match="noise must be a finite number > 0"):
        core.fisher_measures(PAPER_STATE, DUAL15, noise=0.0)
