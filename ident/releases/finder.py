"""`find_releases(t, y)`: every release in a raw record, in time order.

Steps (arrays in, `Release` records out):
1. `motion`: a uniform grid, the dominant period T, smoothed x, v, a per column;
2. the free columns: a cart whose swing is small beside the largest one is held (it may
   wander by a few mm or follow weakly through the spring); the free carts' positions enter
   each other's equations of motion;
3. `hand`: per free column, the force its free equation of motion does not explain, and the
   hand episodes where it is large; weaker but sustained pushes (a held cart moved, which
   moves this one through the spring) also end a free response;
4. a candidate release is the end of a hand episode followed by a free response: at least
   one period without a hand, ringing (a turning point at least) with an amplitude of at least
   a centimetre (`MIN_RELEASE_AMPLITUDE_M`) and well above the noise and the dry-friction
   band, after a hand force comparable with the spring's at that amplitude (a touch while
   the cart rings is not). The pulled cart is the column whose hand episode it is; when a
   held cart moved a fifth as much as this one during the episode, a hand moved the held
   cart (a touch), not a release;
5. `instant`: the release instant, between samples, where the free response begins;
6. the free response ends where the next hand episode on the pulled cart begins (the next
   release or a touch), where the free carts move again after they had come to rest (a touch
   too weak for a hand episode, `restart`) or at the end of the record, cut when the cart
   still rings there.
A record that starts in motion has no hand episode before its first free stretch: that
stretch is the tail of an earlier release, not a release of this record.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentDimensionError
from ident.releases.hand import HAND_SIGMAS, STICK_ALLOWANCE, FreeModel, drift, fit_free_model
from ident.releases.instant import release_instant
from ident.releases.joined import joined_instant
from ident.releases.misfit import free_misfit, rest
from ident.releases.motion import FloatArray, Motion, motion, moving_samples, turning_indices
from ident.releases.record import HELD_FRACTION, EndedBy, Release
from ident.releases.restart import moved_after_rest

#: During a touch the held cart moves at least this fraction of what the pulled cart moves,
TOUCH_FRACTION = 0.2
#: ... and more than this many times its usual wander over as long (`_usual_wander`): a hand
#: holding a cart loosely lets it wander by a few mm (the 2025 records: 100-400 counts, up
#: to 7 mm), a fifth of a 3 cm pull, more over a hold of seconds.
TOUCH_WANDERS = 2.0
#: A release rings: at least this many turning points in its free response (the cart swings
#: out and back; a cart whose slow mode has a long period may be taken again within a cycle).
MIN_TURNS = 1
#: Its first swing exceeds this many metres: students release carts by centimetres (flicks to
#: 3–5 cm, pulls to 15 cm), while handling (nudges, a held cart's wander and touches) moves
#: them by millimetres. `find_releases(min_amplitude_m=...)` changes it.
MIN_RELEASE_AMPLITUDE_M = 0.01
#: ... and this many noise stds and this many dry-friction bands.
MIN_AMPLITUDE_SIGMAS = 30.0
MIN_AMPLITUDE_BANDS = 4.0
#: A hand that lets a ringing cart go where it took it leaves a swing below this many
#: `min_amplitude_m` when it only nudged it (`nudged_while_ringing`).
NUDGE_AMPLITUDE_FACTOR = 2.0
#: ... and whatever its swing when the hand let it go within this many metres of where it took
#: it (a nudge moves the cart 2-8 mm and back) with no more swing than before (this factor
#: allows for the amplitudes' estimates).
NUDGE_RETURN_M = 0.003
NUDGE_SWING_MARGIN = 1.1
#: The hand's largest force on a released cart is at least this fraction of the spring's
#: force at the amplitude of the free response (per unit mass: wn²·A).
HAND_FORCE_FRACTION = 0.3
#: A hand episode that does not move the cart (a still hold) pushes beyond this many kinetic
#: dry-friction forces (static friction holds a stuck cart with at most ~1.3 of them).
STILL_HOLD_BANDS = 3.0
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
#: A sustained push: the residual's moving average over a quarter period beyond this many scales.
SUSTAINED_SIGMAS = 2.5
#: ... and beyond this many times its median over the samples where the cart moves.
TYPICAL_MISFITS = 3.0
#: A cart is stuck where its smoothed position stays within this many noise stds over a
#: smoothing window (`_stuck`).
STUCK_SIGMAS = 4.0
#: A hand episode's force is counted as lasting while its residual stays beyond this many
#: scales (on top of the allowance): a hysteresis below the hand's limit (`HAND_SIGMAS`).
LASTING_SIGMAS = 2.0


def find_releases(t: NDArray[np.float64], y: NDArray[np.float64],
                  carts: Sequence[int] | None = None,
                  min_amplitude_m: float = MIN_RELEASE_AMPLITUDE_M) -> list[Release]:
    """Every release in a record `y` (N,) or (N, n) m on `t` (N,) s, in time order.

    `carts` names the columns (cart numbers, default 1..n); times are on `t`'s time base
    (a non-uniform `t` is interpolated onto a uniform grid from `t[0]`); a free response
    whose first swing is below `min_amplitude_m` (m) is handling, not a release.
    """
    m = motion(t, y)
    n_cols = m.y.shape[1]
    names = tuple(carts) if carts is not None else tuple(range(1, n_cols + 1))
    if len(names) != n_cols:
        raise IdentDimensionError("carts", f"one cart number per column ({n_cols})", len(names))
    free = free_columns(m)
    found: list[tuple[float, int, FreeModel]] = []   # (release time, column, model)
    stops: list[tuple[int, int]] = []              # (column, start index of a hand episode)
    held = [i for i in range(n_cols) if i not in free]
    for j in free:
        # every other cart's position enters: a held cart that wanders or is moved shifts
        # this cart's rest through the spring, which is not a hand on this cart
        model = fit_free_model(m, j, tuple(i for i in range(n_cols) if i != j), tuple(held))
        # a free response's own misfit (an effect of the state the model lacks) is no hand
        episodes = [e for e in hand_episodes(m, model) if not free_misfit(m, model, *e)]
        pushes = [p for p in sustained_pushes(m, model) if not free_misfit(m, model, *p)]
        # where a hand begins to act, conservatively: the derivatives' smoothing (half a window
        # each side) and the sustained pushes' moving average (T/8 each side) see it late
        stops += [(j, max(0, a - m.window // 2)) for a, _ in episodes]
        # a hand moving a held cart (a touch) pushes this one through the spring: seen by the
        # model without the held carts; with none, those are the pushes above (the free
        # response's own misfit is no touch either: it had ended cubic-spring windows within
        # a period, too short to diagnose)
        alone = fit_free_model(m, j, tuple(i for i in free if i != j)) if held else None
        stops += [(j, max(0, a - m.samples(m.period_s / 4)))
                  for a, _ in (sustained_pushes(m, alone) if alone is not None else pushes)]
        steady = [level for e in episodes if (level := steady_level(m, model, *e)) is not None]
        for k, (a, b) in enumerate(episodes):
            # the free stretch lasts until the next hand episode or sustained push
            nxt = min([episodes[k + 1][0]] if k + 1 < len(episodes) else [m.n_samples])
            # (one that only trails the episode by the moving average's width is the episode)
            nxt = min([nxt] + [max(p, b + m.samples(m.period_s / 4)) for p, q in pushes
                               if q > b + m.samples(m.period_s / 2) and _pushes_after(m, model, b, p, q)])
            if (is_release(m, model, a, b, nxt, free, min_amplitude_m)
                    and not held_at_a_steady_level(m, model, a, b, steady)):
                first = release_instant(m, model, a, b)
                joined = joined_instant(m, model, first, float(m.t[a]))
                found.append((first if joined is None else joined, j, model))
    found = _one_per_event(m, sorted(found, key=lambda f: f[0]))
    releases = []
    for number, (when, j, model) in enumerate(found, start=1):
        start = min(int(np.ceil((when - m.t[0]) / m.dt - 1e-9)), m.n_samples - 1)
        later = [a for c, a in stops if c == j and a > start + m.samples(0.5 * m.period_s)]
        end = min(later, default=m.n_samples - 1)
        # a touch too weak for a hand episode still moves carts that had come to rest (with a
        # held cart read, its moves are seen directly, and a stuck cart it drags through the
        # spring as its hand wanders is the held cart's effect on the free response)
        # (a hand episode sees such a move late: where the carts left their rest counts)
        if not held:
            end = min(end, moved_after_rest(m, free, start, m.n_samples - 1) or end)
        releases.append(_record(m, model, number, when, start, end, names, free,
                                _ended_by(end, m, [_index(m, s) for s, _, _ in found])))
    return releases


def free_columns(m: Motion) -> list[int]:
    """Columns that swing at least `HELD_FRACTION` of the largest swing (robust range)."""
    span = np.percentile(m.x, 99.5, axis=0) - np.percentile(m.x, 0.5, axis=0)
    return [j for j in range(m.y.shape[1]) if span[j] >= HELD_FRACTION * float(np.max(span))]


def hand_episodes(m: Motion, model: FreeModel) -> list[tuple[int, int]]:
    """(first, last) indices of the hand episodes: runs of `model.hand` joined across gaps
    shorter than T/8 and ended before a tail of the free response's own misfit
    (`_trim_misfit`), that last at least T/10 (a hand's push; not a blip where dry friction
    flips; from rest, counted while the force stays above `LASTING_SIGMAS` scales,
    `_from_rest_lasting`: a flick read through a coarse lattice may pass the hand's limit
    only at its peak) and move the cart (a
    cart stuck off its rest by dry friction shows a residual but no motion), away from the
    smoothing's edge."""
    edge = m.window // 2 + 2
    mask = model.hand & _inside(m.n_samples, edge)
    runs = _trim_misfit(m, model, _runs(mask, 1), _runs(mask, m.samples(m.period_s / 8)))
    x = m.x[:, model.column]
    floor = 8.0 * float(m.noise_m[model.column])
    shortest = m.samples(m.period_s / 10)
    # a hand holding the cart still (a record that starts while the hand holds it) moves
    # nothing but pushes harder than dry friction can hold it
    held = STILL_HOLD_BANDS * abs(model.dry) + HAND_SIGMAS * model.scale
    lasting = _lasting(m, model)
    stuck = _stuck(m, model.column)
    return [(a, b) for a, b in runs if (b - a >= shortest or _from_rest_lasting(m, lasting, stuck, a, b) >= shortest)
            and (float(np.ptp(x[a:b + 1])) > floor or float(np.max(np.abs(model.residual[a:b + 1]))) > held)]


def _lasting(m: Motion, model: FreeModel) -> NDArray[np.bool_]:
    """Where the residual exceeds `LASTING_SIGMAS` scales beyond the allowance: how long a
    force whose peak passed the hand's limit lasts."""
    allowance = model.allowance if model.allowance is not None else 0.0
    limit = LASTING_SIGMAS * model.scale + allowance
    r = model.residual
    return np.asarray(np.abs(r - drift(r, model.hand, m.samples(2.0 * m.period_s))) > limit)


def _from_rest_lasting(m: Motion, lasting: NDArray[np.bool_], stuck: NDArray[np.bool_], a: int, b: int) -> int:
    """Samples from the start to the end of the run of `lasting` about [a, b] when the cart was
    at rest (`stuck`) for the half period before it, else 0. Nothing in a free response starts
    a cart at rest, so a force that starts it is a hand however briefly it passed the hand's
    limit; inside a ringing, the free response's own misfit (a second mode) lasts too."""
    before = np.flatnonzero(~lasting[:a])
    after = np.flatnonzero(~lasting[b + 1:])
    first = int(before[-1]) + 1 if before.size else 0
    last = b + int(after[0]) if after.size else lasting.size - 1
    still = stuck[max(0, first - m.samples(0.5 * m.period_s)):first]
    return last - first if still.size and bool(np.all(still)) else 0


def _trim_misfit(m: Motion, model: FreeModel, pieces: list[tuple[int, int]],
                 joined: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The `joined` runs ended at their last piece (of `pieces`, the unjoined runs) that is
    not the free response's own misfit (`free_misfit`): a second mode's misfit right after a
    hold, joined to the hold across gaps, carried its episode past the let-go. (Only the
    tail: a nudge of a ringing cart may begin with a weak push.)"""
    off = m.x[:, model.column] - rest(m, model)
    out = []
    for a, b in joined:
        hand = [q for p, q in pieces if a <= p and q <= b and not free_misfit(m, model, p, q, off)]
        out.append((a, max(hand) if hand else b))
    return out


def sustained_pushes(m: Motion, model: FreeModel) -> list[tuple[int, int]]:
    """Weak but sustained hand forces (a quarter-period moving average of |r| beyond
    `SUSTAINED_SIGMAS` scales for at least T/8) that move the cart: a held cart moved by hand pulls this
    one through the spring."""
    width = m.samples(0.25 * m.period_s)
    # dry friction's flips where a swinging cart reverses and the model's error share are not
    # a push; nor is the record's typical misfit
    excess = np.abs(model.residual) if model.push_allowance is None else \
        np.maximum(np.abs(model.residual) - model.push_allowance, 0.0)
    v = m.v[:, model.column]
    # nor is static friction holding a stuck cart off its rest (|r| up to f_s = k·|x - rest|:
    # a Coulomb cart that stopped 1-2 mm off its rest had ended its window as a touch)
    stuck = _stuck(m, model.column)
    excess[stuck] = np.maximum(np.abs(model.residual[stuck]) - STICK_ALLOWANCE * abs(model.dry), 0.0)
    mean = np.convolve(excess, np.ones(width) / width, mode="same")
    moving = moving_samples(v)
    typical = float(np.median(mean[moving])) if np.any(moving) else 0.0
    mask = mean > max(SUSTAINED_SIGMAS * model.scale, TYPICAL_MISFITS * typical)
    edge = width
    mask[:edge] = False
    mask[-edge:] = False
    x = m.x[:, model.column]
    floor = 8.0 * float(m.noise_m[model.column])
    shortest = m.samples(m.period_s / 8)
    return [(a, b) for a, b in _runs(mask, 1) if b - a >= shortest and float(np.ptp(x[a:b + 1])) > floor]


def _stuck(m: Motion, column: int) -> NDArray[np.bool_]:
    """(N,) True where the cart does not move: its smoothed position stays within
    `STUCK_SIGMAS` noise stds (peak to peak) over a smoothing window around the sample (a
    hand moving a stuck cart slowly, at a centimetre a second, moves it by far more)."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d  # deferred: keeps `import ident` fast
    x = m.x[:, column]
    spread = maximum_filter1d(x, m.window) - minimum_filter1d(x, m.window)
    return np.asarray(spread <= STUCK_SIGMAS * float(m.noise_m[column]))


def _pushes_after(m: Motion, model: FreeModel, last: int, first: int, end: int) -> bool:
    """Whether the sustained push [first, end] pushes after the hand episode ending at `last`:
    of a push that began before the episode's end plus the moving average's half-width (T/8),
    only what follows that counts, and not where it is the free response's own misfit (a
    cubic spring's or a second mode's right after a hold, joined to the hold's force by the
    moving average: the whole push is too long to be a misfit)."""
    after = last + m.samples(m.period_s / 8)
    if first >= after:
        return True
    return end - after >= m.samples(m.period_s / 8) and not free_misfit(m, model, after, end)


def _inside(n: int, edge: int) -> NDArray[np.bool_]:
    """(n,) True but for `edge` samples at each end."""
    inside = np.ones(n, dtype=bool)
    inside[:edge] = False
    inside[n - edge:] = False
    return inside


def _runs(mask: NDArray[np.bool_], join: int) -> list[tuple[int, int]]:
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > join)
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    ends = np.concatenate([idx[breaks], [idx[-1]]])
    return [(int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


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
    if turning_points(x[last:stop], max(level / 3.0, 2.0 * band)) < MIN_TURNS:
        return False
    span = x[last:min(stop, last + m.samples(m.period_s))]
    amplitude = 0.5 * float(np.ptp(span))
    if amplitude < max(level, min_amplitude_m):
        return False
    if nudged_while_ringing(m, j, first, last, amplitude, min_amplitude_m) or steady_force(m, model, first, last):
        return False
    # a hand that lets a cart go held it against the spring: its force was comparable with
    # the spring's at the amplitude that follows (a touch while the cart rings is not)
    push = float(np.max(np.abs(model.residual[first:last + 1])))
    if push < HAND_FORCE_FRACTION * float(model.stiffness[0]) * amplitude:
        return False
    lead = max(0, first - m.samples(m.period_s / 8))
    # what the hand moved this cart by: over the episode, or from its rest when it held the
    # cart still (a record that starts on the hold), at least the swing it let go
    own = max(float(np.ptp(x[lead:last + 1])), amplitude)
    held = [i for i in range(m.y.shape[1]) if i not in free]
    moved = {i: float(np.ptp(m.x[lead:last + 1, i])) for i in held}
    return all(moved[i] < TOUCH_FRACTION * own or moved[i] <= TOUCH_WANDERS * _usual_wander(m, i, last + 1 - lead)
               for i in held)


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
    # apart, half a smoothing window inside each end of the episode
    if (last - first > 2 * m.window and returned < NUDGE_RETURN_M
            and amplitude <= NUDGE_SWING_MARGIN * before):
        return True
    return (amplitude <= before and amplitude < NUDGE_AMPLITUDE_FACTOR * min_amplitude_m
            and returned < min_amplitude_m)


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


def _index(m: Motion, when: float) -> int:
    return min(int(np.ceil((when - m.t[0]) / m.dt - 1e-9)), m.n_samples - 1)


def _one_per_event(m: Motion, found: list[tuple[float, int, FreeModel]]) -> list[tuple[float, int, FreeModel]]:
    """Candidates of several columns within half a period are one release: keep the one
    whose cart moved most around it (the pulled cart)."""
    kept: list[tuple[float, int, FreeModel]] = []
    for cand in found:
        if kept and cand[0] - kept[-1][0] < 0.5 * m.period_s:
            if _swing(m, cand) > _swing(m, kept[-1]):
                kept[-1] = cand
            continue
        kept.append(cand)
    return kept


def _swing(m: Motion, cand: tuple[float, int, FreeModel]) -> float:
    start, j = _index(m, cand[0]), cand[1]
    return float(np.ptp(m.x[start:start + m.samples(m.period_s), j]))


def _ended_by(end: int, m: Motion, starts: list[int]) -> EndedBy:
    if end >= m.n_samples - 1:
        return "record_end"
    nearest = min((s - end for s in starts if s >= end), default=None)
    return "release" if nearest is not None and nearest <= m.samples(m.period_s) else "touch"


def _record(m: Motion, model: FreeModel, number: int, when: float, start: int, end: int, names: tuple[int, ...],
            free: list[int], ended_by: EndedBy) -> Release:
    j = model.column
    first = slice(start, min(end, start + m.samples(m.period_s)) + 1)
    amp = 0.5 * np.ptp(m.x[first], axis=0)
    moving = tuple(names[i] for i in range(len(names)) if amp[i] >= HELD_FRACTION * amp[j])
    band = abs(model.dry) / max(float(model.stiffness[0]), 1e-12)
    tail = m.x[max(start, end - m.samples(m.period_s)):end + 1, j]
    rings = float(np.ptp(tail)) > max(10.0 * float(m.noise_m[j]), 2.0 * band)
    complete = not (ended_by == "record_end" and rings)
    return Release(number=number, release_time_s=when, end_time_s=float(m.t[end]),
                   pulled_cart=names[j], moving_carts=moving, amplitudes_m=tuple(float(a) for a in amp),
                   complete=complete, ended_by=ended_by, period_s=m.period_s)
