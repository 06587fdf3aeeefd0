"""A strong cubic spring (its force at the swing changed by up to ±30 %, the red team's range):
its release dated where the hand lets go, and the diagnosis' simulation close enough that its
stepping error is not taken for another effect.

Independent physics: `x'' = -wn² (x + γ x³) - 2 ζ wn x'` solved by `scipy.integrate.solve_ivp`
(DOP853, tight tolerances), released from a still hold at A, `r = γ A²`, a 25 µm encoder
lattice with 2-6 µm of noise after it. The truth is used only in the assertions.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ident.diagnose import diagnose
from ident.releases import find_releases


def _cubic_release(r: float, wn: float, rate_hz: float,
                   rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Samples (t, y) m, the cubic coefficient κ = wn² γ (1/(m² s²)) and the release time (s)."""
    amp, zeta = rng.uniform(0.08, 0.12), rng.uniform(0.02, 0.05)
    gamma = r / amp ** 2
    t_r = rng.uniform(0.8, 1.2)
    t = np.arange(int(rng.uniform(12.0, 18.0) * rate_hz)) / rate_hz

    def rhs(_: float, z: np.ndarray) -> list[float]:
        return [z[1], -wn ** 2 * (z[0] + gamma * z[0] ** 3) - 2 * zeta * wn * z[1]]

    after = t >= t_r
    sol = solve_ivp(rhs, (t_r, t[-1]), [amp, 0.0], t_eval=t[after], method="DOP853", rtol=1e-11, atol=1e-13)
    x = np.where(after, 0.0, amp)
    x[after] = sol.y[0]
    q = 25e-6
    y = np.round(x / q) * q + rng.normal(0.0, rng.uniform(2e-6, 6e-6), x.size)
    return t, y, wn ** 2 * gamma, t_r


@pytest.mark.parametrize(("seed", "r"), [(5, 0.3), (7, 0.3), (3, -0.3)])
def test_a_strong_cubic_spring_at_a_coarse_rate_is_named_alone(seed: int, r: float) -> None:
    # stepped at h·wn 0.2-0.25 the cubic's mid-step force left a ring that drag (seeds 5, 7)
    # or a coupled mode (red team cubic_softening 3001) took up, and a coefficient 0.3-0.4 % off
    rng = np.random.default_rng([12, seed, int(r > 0)])
    wn, rate = rng.uniform(30.0, 40.0), rng.uniform(70.0, 90.0)
    t, y, kappa, _ = _cubic_release(r, wn, rate, rng)
    report = diagnose(t, y).report
    assert report.cause == "cubic_stiffness"
    assert {e.effect for e in report.effects} <= {"cubic_stiffness", "quantization"}, \
        [(e.effect, e.gain_points) for e in report.effects]
    found = next(e for e in report.effects if e.effect == "cubic_stiffness")
    assert found.parameters["cubic_per_m2_s2"] == pytest.approx(kappa, rel=0.002)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_strong_cubic_spring_let_go_from_a_hold_is_dated_within_one_sample(seed: int) -> None:
    # the free model fitted on the whole record (a straight spring) misses the first swing by
    # 10-30 % of the hold's force: the let-go was dated where that misfit ends, up to 70
    # samples late (softening) and 12 (hardening)
    errors = []
    for r in (0.3, -0.3):
        rng = np.random.default_rng([13, seed, int(10 * r) + 5])
        wn, rate = rng.uniform(10.0, 40.0), rng.uniform(200.0, 1000.0)
        t, y, _, t_r = _cubic_release(r, wn, rate, rng)
        found = find_releases(t, y)
        assert len(found) == 1, [f.release_time_s for f in found]
        errors.append((found[0].release_time_s - t_r) * rate)
    assert max(abs(e) for e in errors) <= 1.0, errors
