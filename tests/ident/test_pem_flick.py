"""PEM with the initial state estimated: a flicked window fitted from its first sample.

As MATLAB pem's InitialState='estimate': the carts are let go moving at the release the data
state, their velocities there estimated with the model. Before, PEM modelled a step from rest
and moved its release to where the cart stood still (the first extreme), so on a flicked window
it missed the first swing. Records written from the physics (not by the code under test):
the exact free response of one cart, and of two carts coupled by springs (`scipy.linalg.expm`
of the chain's state matrix), from positions and velocities at the release; seeded noise.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from ident.data import IdData
from ident.prediction_error import pem

SEEDS = range(6)


def one_cart(seed: int) -> tuple[tuple[IdData, np.ndarray], float, float, float]:
    """wn 8-25 rad/s, ζ 0.02-0.1, swing 1-5 cm let go 30° after to 70° before its extreme."""
    rng = np.random.default_rng(seed)
    wn, zeta = float(rng.uniform(8.0, 25.0)), float(rng.uniform(0.02, 0.1))
    swing = float(rng.uniform(0.01, 0.05)) * float(rng.choice([-1.0, 1.0]))
    phase = np.deg2rad(float(rng.uniform(-30.0, 70.0)))
    rate = float(rng.choice([100.0, 200.0, 500.0, 1000.0]))
    x0, v0 = swing * np.cos(phase), swing * wn * np.sin(phase)
    a = np.array([[0.0, 1.0], [-wn**2, -2.0 * zeta * wn]])
    return _free(a, np.array([x0, v0]), rate, rng, [0], 0.002 * abs(swing)), wn, zeta, v0


def _free(a: np.ndarray, state0: np.ndarray, rate: float, rng: np.random.Generator, outputs: list[int],
          noise: float) -> tuple[IdData, np.ndarray]:
    """The exact free response x(t) = e^{A(t - t_r)} x0 about rest 0, read at `outputs`, in a window
    starting one sample before the release (that sample: the same motion run backwards)."""
    release = 1.0 + float(rng.uniform(0.05, 0.95)) / rate
    t = 1.0 - 1.0 / rate + np.arange(0.0, 8.0, 1.0 / rate, dtype=np.float64)
    step = expm(a / rate)
    x = np.empty((t.size, state0.size))
    x[1] = expm(a * (t[1] - release)) @ state0
    x[0] = np.linalg.solve(step, x[1])
    for k in range(2, t.size):
        x[k] = step @ x[k - 1]
    y = x[:, outputs] + rng.normal(0.0, noise, (t.size, len(outputs)))
    clean = x[:, outputs]
    rest = np.mean(y[t > t[-1] - 1.0], axis=0)
    pull = float(rest[0] - np.interp(release, t, y[:, 0]))
    u = np.where(t > release, pull, 0.0)
    return IdData(t, u, y, release_time_s=release), clean


@pytest.mark.parametrize("seed", SEEDS)
def test_second_order_pem_recovers_a_flicked_cart(seed: int) -> None:
    (data, clean), wn, zeta, v0 = one_cart(seed)
    model = pem(data, 2)
    assert model.modes[0].wn == pytest.approx(wn, rel=0.005)
    assert model.modes[0].zeta == pytest.approx(zeta, rel=0.02)
    if model.initial_velocity is not None:   # else let go near an extreme: a release from rest fits as well
        assert float(model.initial_velocity.sum()) == pytest.approx(v0, abs=0.01 * wn * 0.05)
        assert model.release_time_s == data.release_time_s
    y_hat = model.simulate(data.u)
    release = float(data.release_time_s or 0.0)
    after = data.t >= release
    assert np.max(np.abs(y_hat[after, 0] - clean[after, 0])) < 0.02 * np.ptp(clean)


def two_carts(seed: int) -> tuple[tuple[IdData, np.ndarray], np.ndarray, np.ndarray]:
    """wall -k1- m1 -k2- m2 -k3- wall, dampers to ground; cart 2 flicked (moving at the
    release, pulled 1-5 cm), cart 1 let go from where the spring left it."""
    rng = np.random.default_rng(seed)
    m1, m2 = rng.uniform(0.5, 1.5, 2)
    k1, k2, k3 = rng.uniform(100.0, 400.0, 3)
    c1, c2 = rng.uniform(0.3, 2.0, 2)
    mass = np.diag([m1, m2])
    stiff = np.array([[k1 + k2, -k2], [-k2, k2 + k3]])
    a = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(mass, stiff), -np.linalg.solve(mass, np.diag([c1, c2]))]])
    eig = np.linalg.eigvals(a)
    upper = eig[eig.imag > 0]
    wn, zeta = np.abs(upper), -upper.real / np.abs(upper)
    swing = float(rng.uniform(0.01, 0.05)) * float(rng.choice([-1.0, 1.0]))
    state0 = np.array([0.1 * swing * float(rng.uniform(-1, 1)), swing, 0.0, swing * float(rng.uniform(2.0, 12.0))])
    rate = float(rng.choice([200.0, 500.0]))
    order = np.argsort(wn)
    return _free(a, state0, rate, rng, [1, 0], 0.002 * abs(swing)), wn[order], zeta[order]


@pytest.mark.parametrize("seed", range(4))
def test_fourth_order_pem_recovers_two_carts_from_a_flicked_window(seed: int) -> None:
    (data, clean), wn, zeta = two_carts(seed)
    model = pem(data, 4)
    assert [m.wn for m in model.modes] == pytest.approx(list(wn), rel=0.005)
    assert [m.zeta for m in model.modes] == pytest.approx(list(zeta), rel=0.05)
    y_hat = model.simulate(data.u)
    release = float(data.release_time_s or 0.0)
    after = data.t >= release
    assert np.max(np.abs(y_hat[after] - clean[after])) < 0.02 * np.ptp(clean)


def test_a_release_from_rest_keeps_the_zero_initial_state() -> None:
    """A pull-hold-release: the step from rest (its release fitted) is kept."""
    rng = np.random.default_rng(2)
    wn, zeta, pull, rate = 12.0, 0.04, 0.03, 200.0
    t = np.arange(0.0, 8.0, 1.0 / rate, dtype=np.float64)
    release = 1.0 + 0.3 / rate
    a = np.array([[0.0, 1.0], [-wn**2, -2.0 * zeta * wn]])
    x = np.array([(expm(a * max(tk - release, 0.0)) @ np.array([-pull, 0.0]))[0] for tk in t])
    y = (pull + x + rng.normal(0.0, 6e-5, t.size))[:, None]
    model = pem(IdData(t, np.where(t > release, pull, 0.0), y, release_time_s=release + 0.003), 2)
    assert model.initial_velocity is None
    assert model.release_time_s == pytest.approx(release, abs=0.2 / rate)
