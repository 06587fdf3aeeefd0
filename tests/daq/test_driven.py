"""`daq.driven`'s bounded least squares, against `numpy.linalg.lstsq` and a brute-force check.

The driven fit solves a small linear least-squares problem whose coupling coefficients are
bounded. A window over which the cart moves one way makes dry friction's response a sum of
the other columns (an exactly rank-deficient matrix); on one such window scipy's default
`trf` solver's line search never ended (the detector at the end of a testkit record, see
`test_free_pair_releases.py`); these check the solver that replaced it.
"""

from __future__ import annotations

import numpy as np

from daq.driven import _bounded_residual
from daq.ringing import basis, friction_response


def test_a_rank_deficient_window_is_solved_and_keeps_the_least_squares_residual() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(33) / 100.0
    sigma, omega = 0.3, 9.0
    g1, g2, _, _ = basis(t, float(t[0]), sigma, omega)
    one_way = -np.ones_like(t)    # moving one way: friction's response is 1 - a cos - b sin
    a = np.stack([np.ones_like(t), t, friction_response(t, one_way, sigma, omega), g1, g2, rng.normal(size=t.size)],
                 axis=1)
    assert np.linalg.matrix_rank(a) == 5
    y = a @ np.array([0.01, 0.002, 0.0, 0.03, -0.02, 0.4]) + rng.normal(0.0, 1e-4, t.size)
    lo, hi = np.r_[np.full(5, -np.inf), 0.0], np.r_[np.full(5, np.inf), 1.25]
    r = _bounded_residual(a, y, lo, hi)
    best = np.linalg.lstsq(a, y, rcond=None)
    assert np.allclose(r, a @ best[0] - y, atol=1e-12)


def test_a_bound_that_binds_gives_the_constrained_optimum() -> None:
    rng = np.random.default_rng(4)
    a = rng.normal(size=(40, 3))
    y = a @ np.array([1.0, -2.0, 3.0]) + rng.normal(0.0, 0.01, 40)
    lo, hi = np.array([-np.inf, -np.inf, 0.0]), np.array([np.inf, np.inf, 1.25])
    r = _bounded_residual(a, y, lo, hi)
    # the third coefficient sits on its upper bound: the other two are the least squares of the rest
    fixed = np.linalg.lstsq(a[:, :2], y - 1.25 * a[:, 2], rcond=None)[0]
    assert np.allclose(r, a[:, :2] @ fixed + 1.25 * a[:, 2] - y, atol=1e-9)
