import numpy as np
import pytest

# The paper's common parameters (spec §5).
PAPER_STATE = np.array([30.0, 40.0, 120.0, 2.0, 2.0, 100.0, 20.0])


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


def random_states(rng, n, stations):
    """n random valid states, every target ≥ 5 m from every station."""
    out = []
    while len(out) < n:
        pos = rng.uniform([-300, -300, 0], [300, 300, 400])
        if np.min(np.linalg.norm(np.asarray(stations) - pos, axis=1)) < 5:
            continue
        vel = rng.uniform(-4, 4, 2)
        if np.hypot(*vel) < 0.2:
            continue
        out.append(np.r_[pos, vel, rng.uniform(-200, 200, 2)])
    return np.array(out)


def random_stations(rng, n_stations):
    return rng.uniform([-50, -50, 80], [50, 50, 120], (n_stations, 3))
