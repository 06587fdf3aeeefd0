"""Whether a hand episode lets a cart go: the release's rules (step 4 of `finder`). No I/O.

A candidate release is the end of a hand episode followed by a free response: at least one
period without a hand, ringing (a turning point at least) with an amplitude of at least a
centimetre (`MIN_RELEASE_AMPLITUDE_M`) and well above the noise and the dry-friction band,
after a hand force comparable with the spring's at that amplitude. Not releases: a nudge of
a ringing cart (`nudged_while_ringing`), the end of a steady force such as a motor's pulse
(`steady_force`) or a still hold at the level of one (`held_at_a_steady_level`), and a touch
of a held cart (it moved a fifth as much as this one and beyond its usual wander).
"""

from __future__ import annotations

import numpy as np

from ident.releases.hand import FreeModel
from ident.releases.motion import FloatArray, Motion, turning_indices

#: During a touch the held cart moves at least this fraction of what the pulled cart moves,
TOUCH_FRACTION = 0.2
#: ... and more than this many times its usual wander over as long (`_usual_wander`): a hand
#: holding a cart loosely lets it wander by a few mm (the 2025 records: 100-400 counts, up
#: to 7 mm), a fifth of a 3 cm pull, more over a hold of seconds.
TOUCH_WANDERS = 2.0
#: ... and the hand's force on this cart is at most this many times what the held cart's move
#: pulls it by through the spring (k_ji · its move): a hand that holds this cart pulled while
#: the other is moved pushes far harder (red team record 1509 at 50 Hz: 33 m/s² against the
#: coupling's 2-4 from a 13 mm move of the held cart; the release that ended that hold was lost).
TOUCH_FORCE_FACTOR = 2.0
#: A release rings: at least this many turning points in its free response (the cart swings
#: out and back; a cart whose slow mode has a long period may be taken again within a cycle).
MIN_TURNS = 1
#: Its first swing exceeds this many metres: students release carts by centimetres (flicks to
#: 3–5 cm, pulls to 15 cm), while handling (nudges, a held cart's wander and touches) moves
#: them by millimetres. `find_releases(min_amplitude_m=...)` changes it.
MIN_RELEASE_AMPLITUDE_M = 0.01
#: ... over one of the record's periods after the let-go, or to the swing's third turn (out,
#: back and out again) where that comes later, up to this many periods: the record's period is
#: the fast mode's where two carts swing, and the slow one's may be 2-4 times longer (a chain
#: whose slow mode dominates; testkit's effects seed 1147320673, a flick of two free carts:
#: 0.94 s against 0.34 s, its 24 mm swing read 9.8 mm over one period and the release was
#: handling). Read over two periods whatever the turns, the swing after a nudge took in a slow
#: pull by hand 3 s later: a handling record's period (3.3 s) is set by no ringing (red team
#: issue 10, handling 4202 at 50 Hz: a false release).
SWING_PERIODS = 2.0
#: ... and this many noise stds and this many dry-friction bands.
MIN_AMPLITUDE_SIGMAS = 30.0
MIN_AMPLITUDE_BANDS = 4.0
#: A released cart leaves at once: within a quarter period of the hand's last force it moves
#: by more than this share of that swing (one cart does by 0.59-1 of it: from a hold it reaches
#: its centre, and a flick let go φ before its extreme turns there and comes back by (1 - cos φ)
#: + (1 - sin φ) of it; the pulled cart of a chain whose slow mode dominates, with the period
#: the fast one's, by 0.18: testkit's students, seed 3014), and as much in the half period after
#: its first turn (`stays`); a hand that puts a cart back where it stays (a nudge) does not.
LEAVES_SHARE = 0.1
#: A hand that lets a ringing cart go where it took it leaves a swing below this many
#: `min_amplitude_m` when it only nudged it (`nudged_while_ringing`).
NUDGE_AMPLITUDE_FACTOR = 2.0
#: ... and whatever its swing when the hand let it go within this many metres of where it took
#: it (a nudge moves the cart 2-8 mm and back) with no more swing than before (this factor
#: allows for the amplitudes' estimates).
NUDGE_RETURN_M = 0.003
NUDGE_SWING_MARGIN = 1.1
#: ... unless the hand held the cart still before letting it go: it moved by less than this
#: share of the swing that follows over the quarter period before the let-go (a free swing
#: moves by about all of it there; testkit's students' holds 0.1-0.4 %, their nudges of a
#: ringing cart, a 2-8 mm bump and back, 5-8 %)
HELD_STILL_SHARE = 0.02
#: The hand's largest force on a released cart is at least this fraction of the spring's
#: force at the amplitude of the free response (per unit mass: wn²·A).
HAND_FORCE_FRACTION = 0.3
#: A force that stays within this fraction of its level while the cart swings is steady
#: (a motor's input, `steady_force`), not a hand.
STEADY_SPREAD = 0.2
#: ... and "swings" means reversing by more than this share of the displacement the steady
#: force holds the cart at (|level| / k): a motor's step rings about its new rest by 0.6-1.0
#: of it (the ten 2025 ECP-210 motor pulses); a hand holding a pulled cart still moves it by
#: its tremor, 0.1-0.6 % (the 2023 hand holds, the simulated students' holds 0.3-0.6 %), and
#: a loose hand by a few mm on a hold of centimetres (~10 %), which the reading noise alone
#: let count as a swing at 1 kHz.
STEADY_SWING_SHARE = 0.25


def is_release(m: Motion, model: FreeModel, first: int, last: int, nxt: int, free: list[int],
               min_amplitude_m: float = MIN_RELEASE_AMPLITUDE_M) -> bool:
    """Whether the hand episode [first, last] of `model.column` lets a cart go (step 4)."""
    j = model.column
    at_end = nxt >= m.n_samples
    if nxt - last < m.samples(m.period_s * (0.5 if at_end else 1.0)):
        return False   # the hand took hold again within a period: handling
    x = m.x[:, j]
    stop = min(nxt, last + m.samples(3.0 * m.period_s))
    band = abs(model.dry) / max(float(model.stiffness[0]), 1e-12)
    # (the swing is read off the smoothed position: the noise left there counts)
    level = max(MIN_AMPLITUDE_SIGMAS * float(m.x_noise_m[j]), MIN_AMPLITUDE_BANDS * band)
    turns = turning_indices(x[last:stop], max(level / 3.0, 2.0 * band))
    if turns.size < MIN_TURNS:
        return False
    # (the swing over one period sets what the hand's force and the cart's leaving compare with)
    period = m.samples(m.period_s)
    amplitude = 0.5 * float(np.ptp(x[last:min(stop, last + period)]))
    reach = period if turns.size < 3 else min(max(period, int(turns[2]) + 1), m.samples(SWING_PERIODS * m.period_s))
    swing = 0.5 * float(np.ptp(x[last:min(stop, last + reach)]))
    if swing < max(level, min_amplitude_m) or stays(m, x, last, last + int(turns[0]), nxt, amplitude):
        return False
    if nudged_while_ringing(m, j, first, last, amplitude, min_amplitude_m) or steady_force(m, model, first, last):
        return False
    # a hand that lets a cart go held it against the spring: its force was comparable with
    # the spring's at the amplitude that follows (a touch while the cart rings is not)
    push = float(np.max(np.abs(model.residual[first:last + 1])))
    if push < HAND_FORCE_FRACTION * _spring(m, model) * amplitude:
        return False
    lead = max(0, first - m.samples(m.period_s / 8))
    # what the hand moved this cart by: over the episode, or from its rest when it held the
    # cart still (a record that starts on the hold), at least the swing it let go
    own = max(float(np.ptp(x[lead:last + 1])), amplitude)
    held = [i for i in range(m.y.shape[1]) if i not in free]
    moved = {i: float(np.ptp(m.x[lead:last + 1, i])) for i in held}
    return all(moved[i] < TOUCH_FRACTION * own or moved[i] <= TOUCH_WANDERS * _usual_wander(m, i, last + 1 - lead)
               or push > TOUCH_FORCE_FACTOR * _coupling(model, i) * moved[i] for i in held)


def _spring(m: Motion, model: FreeModel) -> float:
    """What a hand holding the cart still holds it against per unit of its pull (1/s²): the
    free model's static stiffness, at most the record's dominant (2π/T)². A cart's static
    stiffness is at most its slow mode's ω² (a light mass it carries on a spring only softens
    it); the fitted one exceeded it 5-fold where the unread mass's two columns traded with the
    cart's own stiffness (red team coupled_light 10300, 466 Hz: an 8.5 Hz mass of 1.3 % share,
    k_jj 2359 /s² for 605; a 13.7 cm hold's 45 m/s² then fell short of its bar and the only
    release of the record was lost)."""
    return min(model.static_stiffness, (2.0 * np.pi / m.period_s) ** 2)


def _coupling(model: FreeModel, column: int) -> float:
    """|k_ji| (1/s²): what a unit move of held cart `column` pulls this cart by through the
    spring (infinite when its position is not in the model: no bound)."""
    if column not in model.others:
        return float("inf")
    return abs(float(model.stiffness[1 + model.others.index(column)]))


def stays(m: Motion, x: FloatArray, last: int, turn: int, nxt: int, amplitude: float) -> bool:
    """Whether the cart stays where the hand left it at `last` (it moves by less than
    `LEAVES_SHARE` of `amplitude` within a quarter period), or stops at its first turn (`turn`:
    as little over the half period after it, when at least a quarter period of it comes before
    the hand's next episode at `nxt`): the hand moved it there, no free response follows. A
    free response of a centimetre or more swings back from its first turn by most of it (dry
    friction of a quarter of it still leaves half), and a record of handling only has no
    ringing to set the period by (red team handling records 701 and 706: 4.4 s, over which a
    nudge and a slow pull's return by hand, each let go where the cart stayed, read as swings)."""
    quarter, half = m.samples(m.period_s / 4), m.samples(m.period_s / 2)
    if float(np.ptp(x[last:min(nxt, last + quarter + 1)])) < LEAVES_SHARE * amplitude:
        return True
    back = x[turn:min(nxt, turn + half + 1)]
    return back.size > quarter and float(np.ptp(back)) < LEAVES_SHARE * amplitude


def _usual_wander(m: Motion, column: int, width: int) -> float:
    """The median range (m) of column `column` over the record's stretches of `width` samples,
    or of a third of the record if that is shorter: how far a held cart moves over that long
    when nobody touches it (its hand's wander and what it follows through the spring; touches
    are a few of the stretches)."""
    x = m.x[:, column]
    width = max(1, min(width, x.size // 3))
    n = x.size // width
    return float(np.median(np.ptp(x[:n * width].reshape(n, width), axis=1)))


def nudged_while_ringing(m: Motion, j: int, first: int, last: int, amplitude: float,
                         min_amplitude_m: float) -> bool:
    """Whether the hand episode [first, last] of column `j` is a nudge of a ringing cart: the
    hand took the cart and let it go within `min_amplitude_m` of where it took it, and the
    cart swings after it (`amplitude`, m) no more than in the period before, and by less
    than `NUDGE_AMPLITUDE_FACTOR`·`min_amplitude_m`: the hand interrupted a free response
    but gave the cart no swing of its own, as a release does. (A flick or a hold that ends
    where the hand took a ringing cart looks the same; it is a release when it leaves a
    swing a student means, of a few centimetres.)"""
    x = m.x[:, j]
    before = 0.5 * float(np.ptp(x[max(0, first - m.samples(m.period_s)):first + 1]))
    # the smoothing sees the hand half a window early and late
    took = float(x[min(first + m.window // 2, last)])
    let_go = float(x[max(last - m.window // 2, first)])
    returned = abs(let_go - took)
    # a hand that put the ringing cart back where it took it, to within a few millimetres,
    # added no swing whatever the swing left: only the swing the cart had (a release let go
    # there by chance leaves its own, larger swing); told only when the two places are read
    # apart, half a smoothing window inside each end of the episode. Not when the hand held
    # the cart still before letting it go: that is a hold's release, wherever the hand took
    # the cart (testkit's students, seed 3048 at 50 Hz: a ringing cart caught at -28 mm and
    # held at -31 mm for a second, then let go to a 25 mm swing, was lost)
    if (last - first > 2 * m.window and returned < NUDGE_RETURN_M
            and amplitude <= NUDGE_SWING_MARGIN * before and not _held_still(m, x, first, last, amplitude)):
        return True
    return (amplitude <= before and amplitude < NUDGE_AMPLITUDE_FACTOR * min_amplitude_m
            and returned < min_amplitude_m)


def _held_still(m: Motion, x: FloatArray, first: int, last: int, amplitude: float) -> bool:
    """Whether the hand held the cart still (within `HELD_STILL_SHARE` of the `amplitude` that
    follows) for the quarter period before it let go at `last` (read half a smoothing window
    inside the episode, as `nudged_while_ringing` reads its ends)."""
    end = max(last - m.window // 2, first)
    start = end - m.samples(m.period_s / 4)
    return start >= first and float(np.ptp(x[start:end + 1])) < HELD_STILL_SHARE * amplitude


def steady_force(m: Motion, model: FreeModel, first: int, last: int) -> bool:
    """Whether the episode [first, last] is a steady force (`steady_level`)."""
    return steady_level(m, model, first, last) is not None


def steady_level(m: Motion, model: FreeModel, first: int, last: int) -> float | None:
    """The level (m/s²) of the episode [first, last] if it is a steady force, not a hand, else
    None. A steady force: over its interior (a
    quarter period in from each end, at least a period long) the cart swings on its own
    (two turning points beyond the noise, the dry-friction band and `STEADY_SWING_SHARE` of
    the displacement the force holds it at) while the unexplained force stays level (robust
    spread below `STEADY_SPREAD` of its level): a motor's voltage pulse, or a held cart moved
    and left. A hand that holds a cart stops it swinging; the
    cart's ringing when such a force ends is a step response, not a release."""
    quarter = m.samples(m.period_s / 4)
    lo, hi = first + quarter, last - quarter
    if hi - lo < m.samples(m.period_s):
        return None
    r = model.residual[lo:hi]
    level = float(np.median(r))
    spread = 1.4826 * float(np.median(np.abs(r - level)))
    k = max(float(model.stiffness[0]), 1e-12)
    swing = max(10.0 * float(m.noise_m[model.column]), 2.0 * abs(model.dry) / k, STEADY_SWING_SHARE * abs(level) / k)
    steady = turning_points(m.x[lo:hi, model.column], swing) >= 2 and spread <= STEADY_SPREAD * abs(level)
    return level if steady else None


def held_at_a_steady_level(m: Motion, model: FreeModel, first: int, last: int, levels: list[float]) -> bool:
    """Whether the episode [first, last] holds the cart still (it moves by less than
    `STEADY_SWING_SHARE` of the displacement its force holds it at: not pulled there) against
    the level of a steady force found elsewhere in the record (`levels`, within
    `STEADY_SPREAD`). Fitted without its input, a cart that rings about a motor's step for
    about as long as it rings after it may have its rest read at the driven position; the
    stillness before the motor's onset then reads as a hand holding the cart still from the
    record's start and letting go at the onset, and the ringing after the pulse as a steady
    force of the same level: both are the one displacement of the rest, not a hand."""
    r = model.residual[first:last + 1]
    level = float(np.median(r))
    k = max(float(model.stiffness[0]), 1e-12)
    if float(np.ptp(m.x[first:last + 1, model.column])) >= STEADY_SWING_SHARE * abs(level) / k:
        return False
    return any(abs(level - other) <= STEADY_SPREAD * abs(other) for other in levels)


def turning_points(x: FloatArray, hysteresis: float) -> int:
    """Number of turning points of `x` that reverse by more than `hysteresis`."""
    return int(turning_indices(x, hysteresis).size)
