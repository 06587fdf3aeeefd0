"""Through a coarse encoder lattice, an effect of the carts is judged by the readings as levels.

A cart on a hardening spring read through a 1.2 mm encoder (`testkit.effects`, its own
integrator): once the lattice is in the model, the forward selection had compared the next
effects by the SSE of the staircase read of the prediction, where moving a level edge by a
few µm counts a whole quantum. A "mode" of tens of µm or a friction of hundredths of a m/s²
moved a few edges and passed (seeds 0-19 below: 2 of 20 runs, a coupled mode of +0.43 and
+0.095 points, a Coulomb friction of +0.037; red team `cubic_hardening` 2903: a 2.04 Hz mode of
23 ± 24 µm, SSE ratio 45 against a bound of 29). Judged by the likelihood of the readings as
the lattice's levels about the carts' positions (`lattice.level_log_likelihood`), they gain
within the noise (2903: 6.5), and the cubic spring and the lattice alone are named (0 of 20).
"""

from __future__ import annotations

import pytest

from ident.diagnose import diagnose
from testkit.effects import judge, make_case

ENCODER_M = 1.2e-3


@pytest.mark.slow
@pytest.mark.parametrize("seed", [11, 14])
def test_a_cubic_read_through_a_coarse_lattice_has_no_spurious_effect(seed: int) -> None:
    case = make_case(seed, "cubic_stiffness", carts=1, encoder_m=ENCODER_M)
    report = diagnose(case.observed.t, case.observed.y, carts=case.observed.carts).report
    found = [(e.effect, round(e.gain_points, 3)) for e in report.effects]
    assert {e for e, _ in found} == {"cubic_stiffness", "quantization"}, found
    assert judge(case, report).errors["cubic_per_m2_s2"] < 0.05, judge(case, report).errors
