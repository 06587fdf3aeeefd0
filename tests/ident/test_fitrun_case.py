"""Which carts `ident fit` fits, from the motion alone (`ident.fitrun.detect_case`).

Records drawn from the physics here: a cart ringing about its rest after a step or a release,
read through an encoder lattice; a held cart that wanders by a fraction of it."""

from __future__ import annotations

import numpy as np
import pytest

from ident.data import IdData
from ident.errors import IdentValueError
from ident.fitrun import detect_case

QUANTUM_M = 1.7857e-5   # one count of the ECP-210's encoder


def _record(steps_m: list[float], seed: int = 0) -> IdData:
    """Columns that rest for 0.5 s, then step by these amounts, ringing at 3.7 Hz (ζ 0.05), on the
    encoder's lattice (a little noise before it), 113 Hz for 6 s."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 6.0, 1.0 / 113.0)
    tau = np.clip(t - 0.5, 0.0, None)
    ring = (1.0 - np.exp(-0.05 * 23.0 * tau) * np.cos(23.0 * tau)) * (t >= 0.5)
    y = np.column_stack([a * ring + rng.normal(0.0, 0.2 * QUANTUM_M, t.size) for a in steps_m])
    return IdData(t, np.zeros_like(t), QUANTUM_M * np.round(y / QUANTUM_M))


@pytest.mark.parametrize("step_m", [0.001, 0.0024])
def test_a_cart_that_moves_a_few_millimetres_moves(step_m: float) -> None:
    # a step that overshoots to 1.9 and 4.5 mm: the 2023 0.5 V open-loop steps move their cart
    # 4.5-4.7 mm, and a 5 mm floor refused them
    assert detect_case(_record([step_m])) == ("cart1", (1,))


def test_a_held_cart_that_wanders_a_sixth_of_the_pulled_ones_swing_is_held() -> None:
    # a step of 6 mm beside 40 mm: past any floor in millimetres, but a held cart by the amplitudes
    assert detect_case(_record([0.006, 0.040])) == ("cart2", (2,))
    assert detect_case(_record([0.040, 0.020])) == ("both", (1, 2))


def test_a_record_that_moves_by_a_count_or_two_is_refused() -> None:
    with pytest.raises(IdentValueError, match="no motion"):
        detect_case(_record([1.5 * QUANTUM_M]))
