"""A hand that moves the held cart while the released one still rings makes no second run.

Written from the physics, independently of `daq.sim`: the released cart on its springs,
`x'' = -(k_c + k_w)/m x + k_c/m x_o(t) - 2 ζ ω_n x'`, the other cart a position `x_o(t)` held
by a hand (it wanders by a few tenths of a mm) and moved by it 3-10 mm in 0.2-0.8 s, 1.5-5 s
after the release (the issue's "move the other cart by hand seconds after a release"), solved
by `scipy.integrate.solve_ivp`, sampled at 50-1000 Hz and quantized to 50 µm counts. Through the
coupling spring the move can make the ringing cart's swing grow by millimetres: the run ends
("handled"), but the ringing that follows is the same free cart driven by the other one, not a
release, and makes no run. The truth (one release) is used only in the assertion.

With dry friction (0.5-10 % of the spring's pull at the release; the real 2025 rig's 0.25-0.32
m/s² are 2-4.5 % of its 3-5 cm flicks' pull; sticking while the spring's pull stays under a
static level 1-1.5 times it) the released cart obeys
`x'' = ... - μ sign(x')` and is integrated in fine fixed steps with the stick rule of Karnopp
(a cart at rest stays there while the net spring force is under the static level); the held
cart then also follows it weakly through the spring (0-10 % of its displacement, as a hand
that gives a little: the issue's "follows the released cart weakly").
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from daq.detector import Released, ReleaseDetector
from daq.held import moving_carts
from testkit.release_tally import detect

Q_M = 5e-5


def _min_jerk(u: np.ndarray) -> np.ndarray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def _min_jerk_at(u: float) -> float:
    """`_min_jerk` of one value (the integrator calls it at every stage)."""
    u = min(max(u, 0.0), 1.0)
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def _record(rng: np.random.Generator, rate_hz: float, dry: bool = False,
            touch_after_s: tuple[float, float] = (1.5, 5.0), touch_mm: tuple[float, float] = (3.0, 10.0)
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """(t (N,), positions (N, 2), the release instant): cart 0 pulled, held, released; cart 1 held
    and moved by hand `touch_mm` `touch_after_s` after the release. `dry`: with Coulomb
    friction and stick on cart 0."""
    wn = rng.uniform(9.0, 16.0)
    share = rng.uniform(0.3, 0.6)                 # k_c / (k_c + k_w): the coupling's share
    zeta = rng.uniform(0.005, 0.03)
    pull = rng.uniform(0.02, 0.05) * rng.choice([-1.0, 1.0])
    t_release = rng.uniform(1.5, 2.5)
    t_touch = t_release + rng.uniform(*touch_after_s)
    touch_m = rng.uniform(*touch_mm) * 1e-3 * rng.choice([-1.0, 1.0])
    touch_s = rng.uniform(0.2, 0.8)
    wander = [(rng.uniform(0.5e-4, 2e-4), 2 * math.pi * rng.uniform(0.2, 1.5), rng.uniform(0, 2 * math.pi))
              for _ in range(3)]
    t_end = t_touch + touch_s + rng.uniform(2.5, 4.0)

    def other(t: float) -> float:
        x = sum(a * math.sin(w * t + p) for a, w, p in wander) - sum(a * math.sin(p) for a, w, p in wander)
        return x + touch_m * _min_jerk_at((t - t_touch) / touch_s)

    def rhs(t: float, z: np.ndarray) -> list[float]:
        return [z[1], -wn ** 2 * (z[0] - share * other(t)) - 2 * zeta * wn * z[1]]

    # held at `pull` until the release (the hand's force ends at once), then free
    t = np.arange(0.0, t_end, 1.0 / rate_hz) + rng.uniform(0.0, 1.0 / rate_hz)
    follow = 0.0
    if dry:
        mu, follow = rng.uniform(0.005, 0.1) * wn * wn * abs(pull), rng.uniform(0.0, 0.1)
        grid = np.arange(t_release, t_end, 1e-4)
        held = sum(a * (np.sin(w * grid + p) - math.sin(p)) for a, w, p in wander)
        held = held + touch_m * _min_jerk((grid - t_touch) / touch_s)
        free = _stick_slip(grid, np.asarray(held), follow, pull, wn, share, zeta, mu,
                           mu * rng.uniform(1.0, 1.5))
        x = np.where(t < t_release, pull, np.interp(t, grid, free))
    else:
        sol = solve_ivp(rhs, (t_release, t_end), [pull, 0.0], dense_output=True, rtol=1e-9, atol=1e-11,
                        max_step=2e-3)
        x = np.where(t < t_release, pull, sol.sol(np.maximum(t, t_release))[0])
    xo = np.array([other(v) for v in t]) + follow * (x - pull)
    pos = np.round(np.stack([x, xo], axis=1) / Q_M) * Q_M
    return t, pos, t_release


def _stick_slip(grid: np.ndarray, other: np.ndarray, follow: float, x0: float, wn: float, share: float,
                zeta: float, kinetic: float, static: float) -> np.ndarray:
    """Positions on `grid` (fine, uniform) of the released cart with Coulomb friction (m/s²) from
    rest at `x0`, the other cart at `other` (on `grid`) plus `follow` times this one's position:
    semi-implicit Euler, a cart at rest held while its spring's pull stays under `static`."""
    step = float(grid[1] - grid[0])
    out = np.empty_like(grid)
    x, v = x0, 0.0
    for i in range(grid.size):
        out[i] = x
        pull = -wn * wn * (x - share * (float(other[i]) + follow * x))
        if v == 0.0 and abs(pull) <= static:
            continue
        a = pull - 2.0 * zeta * wn * v - kinetic * math.copysign(1.0, v if v != 0.0 else pull)
        v_new = v + a * step
        v = 0.0 if v != 0.0 and v_new * v < 0.0 else v_new    # through zero: at rest, judged again
        x += v * step
    return out


@pytest.mark.parametrize(("rate_hz", "dry"), [(50, False), (200, False), (1000, False), (50, True),
                                              (200, True)])
def test_moving_the_held_cart_while_the_other_rings_makes_no_second_run(rate_hz: int, dry: bool) -> None:
    rng = np.random.default_rng(7100 + rate_hz + (50_000 if dry else 0))
    extra = []
    for k in range(10):
        t, pos, t_release = _record(rng, rate_hz, dry)
        found = detect((float(t[i]), tuple(pos[i])) for i in range(t.size))
        assert any(abs(f - t_release) < 0.02 for f in found), (k, found, t_release)
        extra += [(k, round(f, 3)) for f in found if abs(f - t_release) >= 0.02]
    assert not extra, extra


@pytest.mark.parametrize("rate_hz", [50, 200, 1000])
def test_a_held_cart_moved_just_after_the_release_is_still_held(rate_hz: int) -> None:
    # a student moves the held cart 3-12 mm (the red team's range) 0.2-1.3 s after the release,
    # within the detector's first `SPAN_S`: one long swing of that cart, not a free one's swings
    rng = np.random.default_rng(7300 + rate_hz)
    wrong = []
    for k in range(8):
        t, pos, t_release = _record(rng, rate_hz, dry=bool(k % 2), touch_after_s=(0.2, 1.3), touch_mm=(3.0, 12.0))
        detector = ReleaseDetector()
        found = [e.t_release_s for i in range(t.size) for e in detector.feed(float(t[i]), tuple(pos[i]))
                 if isinstance(e, Released)]
        assert [f for f in found if abs(f - t_release) < 0.02], (k, found, t_release)
        # the last run is this release's (a ringing the move turned into a run would be extra)
        moving = moving_carts(1, detector.run_spans_m() or [], swings_m=detector.run_swings_m())
        if moving != [1]:
            wrong.append((k, moving, [round(v * 1e3, 1) for v in detector.run_spans_m() or []]))
    assert not wrong, wrong
