"""Where a free response that dry friction brings to rest ends (issue 10: "stops before the
next release or touch").

The records come from the red team's simulator (`tools/redteam/physics.py`: scipy's
solve_ivp with the stops and break-aways as events, independent of the package), drawn from
the physical description: one cart, 0.5-3 kg on 100-800 N/m, ζ 0.005-0.05, kinetic dry
friction that stops it after 4-25 cycles, static 1-1.5 × kinetic, pulled 3-15 cm and held,
let go; read at 50-1000 Hz (log-uniform) with white noise of 1e-6-1e-4 m.
- Nothing touches it: the free response runs to the record's end. The cart stuck off its
  rest (static friction holds it up to f_s/k away) had been taken for a sustained push and
  the window ended there as a touch (red team, 50 Hz, m 1.2 kg, k 300 N/m: "ended by touch"
  at 3.22 s while the cart still swung 16 mm).
- A second cart that is not read (the 2023 `DOF1_en2_manual2` hand steps read encoder 2
  only) and is held at its rest is moved by hand by 1.5-4 static-friction bands of the read
  cart some seconds after that cart stuck: the spring breaks it away by a few mm or less,
  less than a hand episode's force. The window must end before that.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from ident.releases import find_releases

REDTEAM = Path(__file__).resolve().parents[2] / "tools" / "redteam"
SEEDS = range(5)


@contextmanager
def _physics() -> Iterator[Any]:
    sys.path.insert(0, str(REDTEAM))
    try:
        import physics  # the red team's simulator: independent of the package
        yield physics
    finally:
        sys.path.remove(str(REDTEAM))


def _draw(rng: np.random.Generator) -> dict[str, float]:
    m, k = rng.uniform(0.5, 3.0), rng.uniform(100.0, 800.0)
    pull = rng.uniform(0.03, 0.15)
    cycles = rng.uniform(4.0, 25.0)
    fk = k * pull / (4.0 * cycles)
    return {"m": m, "k": k, "zeta": rng.uniform(0.005, 0.05), "pull": pull, "fk": fk,
            "fs": fk * rng.uniform(1.0, 1.5), "rate": float(np.exp(rng.uniform(np.log(50), np.log(1000)))),
            "noise": float(np.exp(rng.uniform(np.log(1e-6), np.log(1e-4)))), "t_r": rng.uniform(0.5, 1.5)}


def _simulate(physics: Any, chain: Any, held: dict[int, Callable[[float], tuple[float, float]]],
              x0: np.ndarray, t: np.ndarray, t_r: float, after: dict[int, Callable[[float], tuple[float, float]]]
              ) -> np.ndarray:
    """Positions (N, n): `held` carts follow their paths until t_r, `after` ones from then on."""
    chain.held = held
    sim = physics.Simulator(chain, x0, np.zeros(len(x0)), float(t[0]))
    out = sim.run(t_r, t)
    chain.held = after
    rest = sim.run(float(t[-1]) + 1e-9, t)
    return np.asarray(np.where(np.isnan(out), rest, out), dtype=np.float64)


def test_a_cart_that_dry_friction_stopped_off_its_rest_is_not_touched() -> None:
    ended = []
    with _physics() as physics:
        for seed in SEEDS:
            p = _draw(np.random.default_rng([1010, seed]))
            cart = physics.Cart(m=p["m"], c=2 * p["zeta"] * np.sqrt(p["k"] * p["m"]), fk=p["fk"], fs=p["fs"])
            chain = physics.Chain([cart], k1=p["k"])
            t = np.arange(0.0, 15.0, 1.0 / p["rate"])
            hold = physics.quintic(-1.0, -0.5, (p["pull"], 0, 0), (p["pull"], 0, 0))
            x = _simulate(physics, chain, {0: hold}, np.array([p["pull"]]), t, p["t_r"], {})[:, 0]
            y = x + np.random.default_rng(seed).normal(0.0, p["noise"], x.shape)
            releases = find_releases(t, y)
            if len(releases) != 1 or releases[0].ended_by != "record_end":
                listed = [(r.release_time_s, r.end_time_s, r.ended_by) for r in releases]
                ended.append(f"seed {seed} ({p['rate']:.0f} Hz): {listed}")
    assert not ended, "\n".join(ended)


def test_a_touch_of_an_unread_cart_after_the_read_one_stuck_ends_its_window() -> None:
    late = []
    with _physics() as physics:
        for seed in SEEDS:
            rng = np.random.default_rng([1011, seed])
            p = _draw(rng)
            m1, k1, k3 = rng.uniform(0.5, 3.0), rng.uniform(100.0, 800.0), rng.uniform(100.0, 800.0)
            k2 = p["k"] - k3 if p["k"] > k3 + 50.0 else p["k"] / 2
            k3 = p["k"] - k2            # the read cart's springs sum to its k
            cart2 = physics.Cart(m=p["m"], c=2 * p["zeta"] * np.sqrt(p["k"] * p["m"]), fk=p["fk"], fs=p["fs"])
            chain = physics.Chain([physics.Cart(m=m1), cart2], k1=k1, k2=k2, k3=k3)
            # the hand moves the unread cart after the read one stuck: 1.5-4 of its
            # static bands through the spring k2, over 0.2-0.5 s
            shift = rng.uniform(1.5, 4.0) * p["fs"] / k2 * float(rng.choice([-1.0, 1.0]))
            t = np.arange(0.0, 40.0, 1.0 / p["rate"])
            pull = physics.quintic(-1.0, -0.5, (p["pull"], 0, 0), (p["pull"], 0, 0))
            still = physics.quintic(-1.0, -0.5, (0, 0, 0), (0, 0, 0))
            free = _simulate(physics, chain, {0: still, 1: pull}, np.array([0.0, p["pull"]]), t, p["t_r"],
                             {0: still})[:, 1]
            moving = np.flatnonzero(np.abs(np.diff(free)) > 1e-9)
            stuck = float(t[moving[-1] + 1])
            touch = stuck + rng.uniform(1.0, 3.0)
            moved = physics.quintic(touch, touch + rng.uniform(0.2, 0.5), (0, 0, 0), (shift, 0, 0))
            chain = physics.Chain([physics.Cart(m=m1), cart2], k1=k1, k2=k2, k3=k3)
            x = _simulate(physics, chain, {0: still, 1: pull}, np.array([0.0, p["pull"]]), t, p["t_r"],
                          {0: moved})[:, 1]
            end = touch + 3.0
            keep = t < end
            y = x[keep] + np.random.default_rng(seed).normal(0.0, p["noise"], keep.sum())
            releases = find_releases(t[keep], y)
            # the touch has moved the read cart once it leaves where it stuck by 3 noise stds
            left = t[keep][(t[keep] > touch) & (np.abs(x[keep] - x[keep][np.searchsorted(t[keep], touch)])
                                                > 3.0 * p["noise"])]
            if not left.size:
                continue        # the spring did not break it away: nothing to see
            if len(releases) != 1 or not stuck - 0.5 < releases[0].end_time_s <= left[0]:
                late.append(f"seed {seed} ({p['rate']:.0f} Hz): stuck {stuck:.2f} s, touched {touch:.2f} s, "
                            f"moved {left[0]:.3f} s; listed "
                            f"{[(r.release_time_s, r.end_time_s, r.ended_by) for r in releases]}")
    assert not late, "\n".join(late)
