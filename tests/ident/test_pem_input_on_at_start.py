"""A force input already on at the record's first sample (a drive switched on as the record
starts, as the 2023 open-loop `DOF1_en1_input1_test4`): the carts rest at 0 under a zero input
before it. Every model starts from rest at u = 0, so such an input is fitted and simulated as
switched on at the first sample, not as a release at its first recorded change.

The record is the exact zero-order-hold response of x'' + 2ζωn x' + ωn² x = b u (scipy's
`cont2discrete`, independent of `ident`), u = 0.5 for 3 s and 0 after, seeded noise."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from ident import IdData, pem
from ident.data import input_jumps

WN, ZETA, B, TS = 23.0, 0.14, -3.0, 0.01


def _record(seed: int) -> IdData:
    t = np.arange(600) * TS
    u = np.where(t < 3.0, 0.5, 0.0)
    a = np.array([[0.0, 1.0], [-WN ** 2, -2 * ZETA * WN]])
    phi, gamma, *_ = scipy.signal.cont2discrete((a, np.array([[0.0], [B]]), np.eye(2), np.zeros((2, 1))), TS)
    x = np.zeros(2)
    y = np.empty(t.size)
    for k in range(t.size):
        y[k] = x[0]
        x = phi @ x + gamma[:, 0] * u[k]
    noise = np.random.default_rng(seed).normal(0.0, 2e-5, t.size)
    return IdData(t, u, (y + noise)[:, None])


def test_an_input_on_at_the_first_sample_is_a_jump_there() -> None:
    assert input_jumps(np.array([0.5, 0.5, 0.0, 0.0])).tolist() == [-1, 1]
    assert input_jumps(np.array([0.0, 0.5, 0.5])).tolist() == [0]
    assert input_jumps(np.array([0.2, 0.2])).tolist() == [-1]


@pytest.mark.parametrize("seed", [1, 2])
def test_pem_fits_an_input_switched_on_at_the_first_sample(seed: int) -> None:
    data = _record(seed)
    model = pem(data, 2)
    assert model.release_time_s is None   # the input as recorded, not a release at 3 s
    assert model.modes[0].wn == pytest.approx(WN, rel=0.01)
    assert model.modes[0].zeta == pytest.approx(ZETA, rel=0.05)
    assert model.fit_percent[0] > 97.0
    # its free run starts from rest at a zero input: the first 3 s are the step's response
    y_hat = model.simulate(data.u)
    assert float(np.max(np.abs(y_hat[:300, 0] - data.y[:300, 0]))) < 0.05 * float(np.ptp(data.y))
