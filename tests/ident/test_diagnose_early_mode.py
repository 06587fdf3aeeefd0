"""A second mode that is hard to see is found at its frequency: one that rings out within the
first seconds, and one a quarter to a third away from the cart's own.

One cart with a second mass on a spring, read at the cart, is a sum of two damped rings
after a release: the cart's mode and the second mass's (the linear system's own modes; closed
form here, `testkit.effects.rings`, not `ident`).

- Early: when the second mode decays at 1-3 /s, most of its energy lies in the window's first
  second or two. The blocked cross-validation's anchoring stretch, never held out, was a sixth
  of the window (1.5 s of a 9 s record): it held the mode's evidence, and the held-out ratio
  fell under its bound while the whole-window ratio was 8-45 times over it (the bench's
  coupled_mode seed 1958525349 at seed 12 before the generator's visibility fix; red team
  coupled_pinned seed 203). The anchor now is one period of the main mode. Cases: seeded
  draws over the generator's coupled-mode ranges with the decay at 1-3 /s.
- Close: a partly pinned second cart of comparable mass (issue 11: "coupled modes, from a light
  mass on a stiff spring to a partly pinned second cart of comparable mass") can ring 1.25-1.33
  times the cart's own frequency, or as far below it. The searched mode was kept a quarter of
  the main frequency away (ratio ≥ 1.333, so that it could not beat with it like an
  amplitude-dependent envelope): red team `coupled_pinned` 9505 (modes 2.82 and 3.74 Hz, ratio
  1.328) had its mode held at the zone's edge, 2.11 Hz, and named quadratic drag and the
  lattice instead, 1.42 points under the noise floor; on these cases it came out 1-4 % off at
  the zone's edge, or as a cubic spring. The zone is now a fifth when the residual's strongest
  peak lies between the two (`ident.diagnose.bounds.CLOSE_MODE_GAP`). Cases: the second ring at
  1.27-1.33 times the main frequency or its inverse, 1-3 % of the pull, decaying at 0.5-1.5 /s.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from testkit.effects.rings import released_with_second_ring


def _two_rings(rng: np.random.Generator, close: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """(t, y, mode_hz): a pull-hold release; early: at 50-400 Hz, 9 s, the second mode 1.6-4 times
    the main one with an amplitude of 8-20 noise std at the release, decaying at 1-3 /s; close:
    at 100-500 Hz, 8 s, the second mode as the module docstring says."""
    rate = float(np.exp(rng.uniform(np.log(100.0), np.log(500.0)) if close
                        else rng.uniform(np.log(50.0), np.log(400.0))))
    wn, zeta = (rng.uniform(8.0, 25.0), rng.uniform(0.005, 0.04)) if close else \
        (rng.uniform(5.0, 20.0), rng.uniform(0.005, 0.03))
    if close:
        ratio = rng.uniform(1.27, 1.33)
        f2 = (ratio if rng.random() < 0.5 else 1.0 / ratio) * wn / (2 * np.pi)
        pull, t_r = rng.uniform(0.05, 0.15), rng.uniform(0.3, 1.0)
        a2, decay2 = rng.uniform(0.01, 0.03) * pull, rng.uniform(0.5, 1.5)
        noise = float(np.exp(rng.uniform(np.log(5e-6), np.log(5e-5))))
    else:
        f2 = rng.uniform(1.6, 4.0) * wn / (2 * np.pi)
        decay2 = rng.uniform(1.0, 3.0)
        noise = float(np.exp(rng.uniform(np.log(5e-6), np.log(1e-4))))
        pull, t_r = rng.uniform(0.05, 0.15), rng.uniform(0.3, 1.0)
        a2 = rng.uniform(8.0, 20.0) * noise
    t = np.arange(0.0, t_r + (8.0 if close else 9.0), 1.0 / rate)
    x = released_with_second_ring(t, t_r, pull, wn, zeta * wn, a2, f2, decay2)
    return t, x + rng.normal(0.0, noise, t.size), float(f2)


def _mode_found(t: np.ndarray, y: np.ndarray, f2: float, rel: float, alone: bool) -> None:
    report = diagnose(t, y, carts=1).report
    found = {e.effect: e for e in report.effects}
    assert report.cause == "coupled_mode", (f2, [(e.effect, e.gain_points) for e in report.effects],
                                            [(c.effect, c.lr_train, c.lr_validation) for c in report.candidates])
    if alone:
        assert set(found) <= {"coupled_mode", "quantization"}, sorted(found)
    assert abs(found["coupled_mode"].parameters["mode_hz"] / f2 - 1.0) < rel


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_a_second_mode_that_rings_out_early_is_found(seed: int) -> None:
    _mode_found(*_two_rings(np.random.default_rng([20261127, seed]), close=False), rel=0.05, alone=False)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_a_second_mode_close_to_the_cart_s_own_is_found(seed: int) -> None:
    # within 1 %: a mode held at the old zone's edge came out 1-4 % off (12 draws: within 0.2 % now)
    _mode_found(*_two_rings(np.random.default_rng([20261202, seed]), close=True), rel=0.01, alone=True)
