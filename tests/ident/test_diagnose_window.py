"""The diagnosis' window on a damped dry-friction ring released far from the spring's rest.

A cart held 8 cm from its rest and released with viscous damping (ζ ≈ 0.08) and Coulomb
friction rings out within two seconds and then sits at its rest for the remaining seconds:
the position is mostly a step from the hold to the rest, whose 1/ω² spectrum outweighs the
short ring. The window took its modes from that step (0.9 rad/s for a 17 rad/s ring), its
scan then ran out of samples and the modal fit crashed ("Initial guess is outside of provided
bounds"). Its first fix, the velocity's spectrum, then lost noisy rings to the differenced
reading noise. The records come from a plain fine-step integration in this test, not from `ident`.

And a clock whose first step is short: the window's simulation steps by the stamps' line.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from testkit.effects import make_case

FINE_S = 2e-5


def ring(wn: float, zeta: float, kinetic: float, static: float, start_m: float,
         length_s: float) -> tuple[np.ndarray, np.ndarray]:
    """x'' = -wn² x - 2ζ wn x' - kinetic·sign(x') from rest at `start_m`, on a grid of FINE_S;
    a cart at rest stays there while wn² |x| <= `static` (semi-implicit Euler, sticking when
    the velocity changes sign and the spring cannot break the static level)."""
    n = int(length_s / FINE_S)
    x = np.empty(n)
    pos, vel = start_m, 0.0
    stuck = wn**2 * abs(pos) <= static
    for i in range(n):
        x[i] = pos
        if stuck:
            continue
        acc = -wn**2 * pos - 2.0 * zeta * wn * vel - kinetic * np.sign(vel if vel != 0.0 else -pos)
        new_vel = vel + FINE_S * acc
        if vel != 0.0 and np.sign(new_vel) != np.sign(vel) and wn**2 * abs(pos) <= static:
            stuck, vel = True, 0.0
            continue
        vel = new_vel
        pos += FINE_S * vel
    return np.arange(n) * FINE_S, x


@pytest.mark.parametrize(("wn", "zeta", "rate_hz", "noise_m", "pull_m"), [
    (17.0, 0.08, 686.0, 1e-5, 0.082), (12.0, 0.1, 200.0, 1e-5, 0.082), (25.0, 0.06, 1000.0, 1e-5, 0.082),
    # a 2 cm pull read with 0.1 mm noise at 555 Hz: a velocity spectrum peaks at the differenced noise
    (14.7, 0.03, 555.0, 1e-4, 0.02)])
def test_a_damped_ring_released_far_from_rest_is_fitted_at_its_own_frequency(wn: float, zeta: float,
                                                                             rate_hz: float, noise_m: float,
                                                                             pull_m: float) -> None:
    kinetic = 1.0
    tf, xf = ring(wn, zeta, kinetic, 1.4 * kinetic, -pull_m, 4.3)
    release = 0.5
    t = np.arange(0.0, 4.8, 1.0 / rate_hz, dtype=np.float64)
    x = np.where(t < release, -pull_m, np.interp(t - release, tf, xf))
    y = x + pull_m + np.random.default_rng(int(rate_hz)).normal(0.0, noise_m, t.size)
    report = diagnose(t, y[:, None], carts=1).report
    assert report.extended.parameters["wn_rad_s"] == pytest.approx(wn, rel=0.05)
    assert abs(report.release_time_s - release) < 2.0 / rate_hz


def test_a_clock_whose_first_step_is_short_leaves_the_frequency_where_it_is() -> None:
    """Stamps within 1 % of each other pass as a uniform grid, but the simulation stepped by
    t[1] - t[0]: with the first step 0.9 % short (a logger whose clock rounds) the fitted wn
    came out 0.9 % high on every case. Now the stamps' least-squares line sets the step."""
    case = make_case(5, "none", carts=1)
    t = case.observed.t.copy()
    t[0] += 0.009 * (t[1] - t[0])
    report = diagnose(t, case.observed.y, carts=1).report
    assert report.corrected_linear["wn_rad_s"] == pytest.approx(case.truth.details["wn_rad_s"], rel=1e-3)
