"""A free response's own misfit, told from a hand: an episode in the middle of a swing whose
force is far below what a hand needs to take the cart.

A free model that lacks an effect of the state (a cubic spring: k3·x³ is 3-30 % of k·x at
the swing's extremes; a second mode of a light or pinned mass, whose acceleration grows with
the square of its frequency) leaves a residual that peaks once or twice a cycle while the
cart rings. Where it crosses the hand's limit it looks like a short hand episode and, right
after a release, like a hand taking the cart again within a period (the release was then
rejected as handling, and its free response cut there).

A hand that takes a cart swinging by A must stop it: at least the spring's force near the
extreme, `finder.HAND_FORCE_FRACTION`·ω²·A per unit mass (the rule a releasing hand
already meets). An episode that stays below that, lasts under half a period (the cart keeps
swinging through it: a hold stops it) and leaves no more swing than the cart had (a hand
that gave it energy is a push) is the free response's misfit, not a hand. No I/O.
"""

from __future__ import annotations

import numpy as np

from ident.releases.hand import FreeModel, period_average
from ident.releases.motion import Motion

#: A hand that takes a swinging cart pushes with at least this fraction of ω²·A (the swing's
#: spring force per unit mass); the same fraction a releasing hand meets (`finder`).
TAKE_FORCE_FRACTION = 0.3
#: ... and its episode lasts at most this many periods when the cart swings through it.
MAX_MISFIT_PERIODS = 0.5
#: The swing after a misfit is at most this factor of the swing before (the estimates' error).
SWING_MARGIN = 1.1


def free_misfit(m: Motion, model: FreeModel, first: int, last: int) -> bool:
    """Whether the episode [first, last] (indices) of `model.column` is the free response's
    own misfit: within a swing of amplitude A (the largest |x - rest| over the period before
    `first`, m; `rest`), shorter than `MAX_MISFIT_PERIODS`·T, its largest |residual| (m/s²) below
    `TAKE_FORCE_FRACTION`·k·A, and the swing over the period after `last` at most
    `SWING_MARGIN`·A (measured alike)."""
    period = m.samples(m.period_s)
    if first < period or last - first > m.samples(MAX_MISFIT_PERIODS * m.period_s):
        return False
    off = m.x[:, model.column] - rest(m, model)
    before = float(np.max(np.abs(off[first - period:first + 1])))
    after = float(np.max(np.abs(off[last:last + period + 1])))
    if after > SWING_MARGIN * before:
        return False
    push = float(np.max(np.abs(model.residual[first:last + 1])))
    return push < TAKE_FORCE_FRACTION * float(model.stiffness[0]) * before


def rest(m: Motion, model: FreeModel) -> np.ndarray:
    """The cart's spring equilibrium (N,) m as the other carts' positions set it: (b - Σ_i k_ji
    x_i)/k_jj, a held cart's position by its period average as the model takes it."""
    load = np.zeros(m.n_samples)
    for k, i in zip(model.stiffness[1:], model.others, strict=True):
        load += float(k) * (period_average(m, m.x[:, i]) if i in model.slow else m.x[:, i])
    return np.asarray((model.offset - load) / max(float(model.stiffness[0]), 1e-12), dtype=np.float64)
