"""`fit_simple(..., "euler", friction=True)` over the whole physical range (issue 11 item 5).

Each run is written from the physics, independently of `ident`: the piecewise-exact free
response of a cart with viscous and dry friction (`testkit.free_ring.coulomb_ring`, static =
kinetic friction, the simple model's own law). Ranges (the lab's carts, the red team's
`euler_coulomb` family): wn 5.8-40 rad/s (m 0.5-3 kg, k 100-800 N/m), ζ 0.005-0.05, a pull of
3-15 cm on either side, dry friction that stops the ring after 4-25 cycles
(f = wn² |pull| / (4 n)), 50-1000 Hz (log-uniform), 1 µm noise, an encoder zero anywhere.
Held and let go from rest, or flicked (let go moving, 30° after to 70° before the extreme);
the fit is called as a lab user calls it, with the release they know and the pull's size.
wn, ζ and f within 1 %: before, the friction fit started from the linear fit's ζ (which has
the dry friction's decay in it) and stalled in local minima (ζ up to 165 % and f 91 % off),
and a pull given with the other sign than the cart's travel was refused (gain < 0).
"""

from __future__ import annotations

import numpy as np
import pytest

import ident
from ident.data import IdData
from ident.errors import FitFailed
from testkit.free_ring import coulomb_ring

SEEDS = range(4)


def friction_run(seed: int, kind: str) -> tuple[IdData, dict[str, float]]:
    rng = np.random.default_rng([11, seed, kind == "flick"])
    wn = float(np.exp(rng.uniform(np.log(5.8), np.log(40.0))))
    zeta = float(rng.uniform(0.005, 0.05))
    pull = float(rng.uniform(0.03, 0.15)) * float(rng.choice([-1.0, 1.0]))
    cycles = float(rng.uniform(4.0, 25.0))
    friction = wn**2 * abs(pull) / (4.0 * cycles)
    rate = float(np.exp(rng.uniform(np.log(50.0), np.log(1000.0))))
    release = float(rng.uniform(0.3, 1.0))
    x0, v0 = -pull, 0.0
    if kind == "flick":
        phase = np.deg2rad(float(rng.uniform(-30.0, 70.0)))
        x0, v0 = -pull * np.cos(phase), -pull * wn * np.sin(phase)
    stop = 2.0 * np.pi / wn * cycles + 1.0
    t = np.arange(0.0, release + min(max(stop, 5.0), 20.0), 1.0 / rate, dtype=np.float64)
    tau = t - release
    x = x0 + v0 * np.minimum(tau, 0.0)   # held still, or the hand's last motion
    x[tau >= 0] = coulomb_ring(tau[tau >= 0], x0, v0, 0.0, wn, zeta, friction)
    y = x + float(rng.uniform(-0.01, 0.01)) + rng.normal(0.0, 1e-6, t.size)
    truth = {"wn": wn, "zeta": zeta, "friction": friction}
    return ident.from_release(t, y, release_time_s=release, amplitude=abs(pull)), truth


@pytest.mark.parametrize("kind", ["hold", "flick"])
@pytest.mark.parametrize("seed", SEEDS)
def test_euler_with_friction_is_within_1_percent_over_the_range(seed: int, kind: str) -> None:
    data, truth = friction_run(seed, kind)
    fit = ident.fit_simple(data, "euler", friction=True)
    for name in ("wn", "zeta", "friction"):
        assert getattr(fit, name) == pytest.approx(truth[name], rel=0.01), (name, truth)
    assert fit.euler_display is not None   # the handout's recursion, shown beside it


@pytest.mark.parametrize("seed", SEEDS)
def test_a_fit_from_rest_is_never_returned_above_the_samples_nyquist_frequency(seed: int) -> None:
    """A flick fitted as a release from rest (the wrong start: it cannot follow the cart's
    velocity at the let-go) may run off; it is refused, never returned with a wn the samples
    cannot show (seed 2, 123 Hz: wn 390.6 rad/s against a Nyquist frequency of 385.7 and a
    truth of 22.9, fit 20.7 %, returned as a fit before)."""
    data, _ = friction_run(seed, "flick")
    nyquist = np.pi / float(data.t[1] - data.t[0])
    try:
        fit = ident.fit_simple(data, "euler", friction=True, initial_state="rest")
    except FitFailed as exc:
        assert "expected" in str(exc)
        return
    assert fit.wn < nyquist
