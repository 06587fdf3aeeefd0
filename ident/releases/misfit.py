"""A free response's own misfit, told from a hand: an episode in the middle of a swing whose
force is far below what a hand needs to take the cart.

A free model that lacks an effect of the state (a cubic spring: k3·x³ is 3-30 % of k·x at
the swing's extremes; a second mode of a light or pinned mass, whose acceleration grows with
the square of its frequency) leaves a residual that peaks once or twice a cycle while the
cart rings. Where it crosses the hand's limit it looks like a short hand episode and, right
after a release, like a hand taking the cart again within a period (the release was then
rejected as handling, and its free response cut there).

A hand that takes a cart swinging by A must stop it, or hold it against the spring: a force
of half the spring's near the extreme, `TAKE_FORCE_FRACTION`·ω²·A per unit mass. An episode
that stays below that, lasts under half a period (the cart keeps swinging through it: a hold
stops it) and leaves no more swing than the cart had (a hand that gave it energy is a push)
is the free response's misfit, not a hand; a part of a hand episode, or a sustained push, is
so below the force a releasing hand meets (`PART_FORCE_FRACTION`). A longer one (a
second mode beating with the first, a cubic's misfit twice a cycle joined by the pushes'
moving average) is judged so half a period at a time. No I/O.
"""

from __future__ import annotations

import itertools

import numpy as np

from ident.releases.hand import FreeModel, period_average
from ident.releases.motion import FloatArray, Motion

#: A hand that takes a swinging cart pushes with at least this fraction of ω²·A (the swing's
#: spring force per unit mass): to stop it mid-swing within a quarter period, (2/π) ω²·A;
#: at its extreme, it then holds it against the spring for longer than the episode may last.
#: A second mode's misfit right after a hold's let-go reaches 0.4 of it (red team
#: `coupled_span` 1500, a 0.75 kg cart pinned beside a 2.8 kg one: the hold was taken for
#: handling and the release dated 141 ms late, at that misfit).
TAKE_FORCE_FRACTION = 0.5
#: The parts of a hand episode and the sustained pushes are told from the free response's
#: misfit at the fraction a releasing hand meets (`judge.HAND_FORCE_FRACTION`): a hand easing
#: off before it lets go pushes with less than it takes a cart with (at 0.5, the last 60 ms of a
#: flick were cut from its episode and the release dated 77 ms early: testkit students, seed
#: 3029 at 50 Hz).
PART_FORCE_FRACTION = 0.3
#: ... and its episode lasts at most this many periods when the cart swings through it.
MAX_MISFIT_PERIODS = 0.5
#: The swing after a misfit is at most this factor of the swing before (the estimates' error).
SWING_MARGIN = 1.1


def free_misfit(m: Motion, model: FreeModel, first: int, last: int, off: FloatArray | None = None,
                fraction: float = PART_FORCE_FRACTION) -> bool:
    """Whether the episode [first, last] (indices) of `model.column` is the free response's
    own misfit (`misfit_part`), judged `MAX_MISFIT_PERIODS` of a period at a time when it is
    longer: a misfit that stays above the hand's limit for cycles (a second mode beating
    with the first, a cubic spring's twice a cycle joined by a moving average) is below a
    hand's force in each part, and the cart swings on through it with no more swing than
    before; a hand that holds or moves the cart is above it in some part. `off` (N,) m is
    x - `rest` when known (it is computed otherwise); `fraction` of ω²·A is the force a hand
    exceeds (`TAKE_FORCE_FRACTION` for a whole episode, `PART_FORCE_FRACTION` for its parts
    and for pushes)."""
    step = m.samples(MAX_MISFIT_PERIODS * m.period_s)
    parts = max(1, int(np.ceil((last - first) / step)))
    bounds = np.linspace(first, last, parts + 1).round().astype(int)
    off = m.x[:, model.column] - rest(m, model) if off is None else off
    return all(misfit_part(m, model, int(lo), int(hi), off, fraction) for lo, hi in itertools.pairwise(bounds))


def misfit_part(m: Motion, model: FreeModel, first: int, last: int, off: FloatArray,
                fraction: float = PART_FORCE_FRACTION) -> bool:
    """Whether the part [first, last] (indices) of an episode of `model.column` is the free
    response's own misfit: within a swing of amplitude A (the largest |x - rest| over the
    period before `first`, at least half a period of record, m; `rest`), no longer than
    `MAX_MISFIT_PERIODS`·T, its largest |residual| (m/s²) below `fraction`·k·A,
    and the swing over the period after `last` at most `SWING_MARGIN`·A (measured alike);
    `off` (N,) m is x - `rest`."""
    period = m.samples(m.period_s)
    # (half a period before is enough when the record starts later: a hold's offset is A)
    if first < period // 2 or last - first > m.samples(MAX_MISFIT_PERIODS * m.period_s):
        return False
    before = float(np.max(np.abs(off[max(0, first - period):first + 1])))
    after = float(np.max(np.abs(off[last:last + period + 1])))
    if after > SWING_MARGIN * before:
        return False
    push = float(np.max(np.abs(model.residual[first:last + 1])))
    return push < fraction * float(model.stiffness[0]) * before


def rest(m: Motion, model: FreeModel) -> np.ndarray:
    """The cart's spring equilibrium (N,) m as the other carts' positions set it: (b - Σ_i k_ji
    x_i)/k_jj, a held cart's position by its period average as the model takes it."""
    load = np.zeros(m.n_samples)
    for k, i in zip(model.stiffness[1:], model.others, strict=True):
        load += float(k) * (period_average(m, m.x[:, i]) if i in model.slow else m.x[:, i])
    return np.asarray((model.offset - load) / max(float(model.stiffness[0]), 1e-12), dtype=np.float64)
