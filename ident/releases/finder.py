"""`find_releases(t, y)`: every release in a raw record, in time order.

Steps (arrays in, `Release` records out):
1. `motion`: a uniform grid, the dominant period T, smoothed x, v, a per column;
2. the free columns: a cart whose swing is small beside the largest one is held (it may
   wander by a few mm or follow weakly through the spring); the free carts' positions enter
   each other's equations of motion;
3. `hand`: per free column, the force its free equation of motion does not explain, and the
   hand episodes where it is large; weaker but sustained pushes (a held cart moved, which
   moves this one through the spring) also end a free response;
4. `judge`: a candidate release is the end of a hand episode followed by a free response
   that rings by at least a centimetre after a hand force comparable with the spring's;
   not a nudge, the end of a steady force (a motor's pulse) or a touch of a held cart;
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

from ident.errors import IdentDimensionError, IdentValueError
from ident.releases.hand import HAND_SIGMAS, STICK_ALLOWANCE, FreeModel, drift, fit_free_model
from ident.releases.instant import release_instant
from ident.releases.joined import joined_instant
from ident.releases.judge import MIN_RELEASE_AMPLITUDE_M, held_at_a_steady_level, is_release, steady_level
from ident.releases.misfit import TAKE_FORCE_FRACTION, free_misfit, rest
from ident.releases.motion import Motion, motion, moving_samples
from ident.releases.record import HELD_FRACTION, EndedBy, Release
from ident.releases.restart import moved_after_rest

#: A hand episode that does not move the cart (a still hold) pushes beyond this many kinetic
#: dry-friction forces (static friction holds a stuck cart with at most ~1.3 of them).
STILL_HOLD_BANDS = 3.0
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
    whose first swing is below `min_amplitude_m` (m) is handling, not a release. A record
    with a NaN or an infinite value is refused (`IdentValueError`, naming the sample).
    """
    finite = np.isfinite(np.reshape(np.asarray(y, dtype=np.float64), (len(t), -1))).all(axis=1) & np.isfinite(t)
    if not finite.all():   # (a NaN spreads through the smoothing and the fits: nothing found, silently)
        raise IdentValueError("record", "finite times and positions (cut the record before a gap, or fill it)",
                              f"a non-finite value at sample {int(np.argmin(finite))} of {finite.size}")
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
        episodes = [e for e in hand_episodes(m, model)
                    if not free_misfit(m, model, *e, fraction=TAKE_FORCE_FRACTION)]
        # a cart another free one pulls (read, or an unread mass) creeps where it stops
        partner = len(free) > 1 or model.hidden is not None
        pushes = [p for p in sustained_pushes(m, model, partner) if not free_misfit(m, model, *p)]
        # where a hand begins to act, conservatively: the derivatives' smoothing (half a window
        # each side) and the sustained pushes' moving average (T/8 each side) see it late
        stops += [(j, max(0, a - m.window // 2)) for a, _ in episodes]
        # a hand moving a held cart (a touch) pushes this one through the spring: seen by the
        # model without the held carts; with none, those are the pushes above (the free
        # response's own misfit is no touch either: it had ended cubic-spring windows within
        # a period, too short to diagnose)
        alone = fit_free_model(m, j, tuple(i for i in free if i != j), unread=False) if held else None
        stops += [(j, max(0, a - m.samples(m.period_s / 4)))
                  for a, _ in (sustained_pushes(m, alone, partner) if alone is not None else pushes)]
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


def sustained_pushes(m: Motion, model: FreeModel, pulled_by_free: bool = False) -> list[tuple[int, int]]:
    """Weak but sustained hand forces (a quarter-period moving average of |r| beyond
    `SUSTAINED_SIGMAS` scales for at least T/8) that move the cart: a held cart moved by hand pulls this
    one through the spring. `pulled_by_free`: another free cart pulls this one (read, or an
    unread mass), so a slow creep where it stops is that pull (below)."""
    width = m.samples(0.25 * m.period_s)
    # dry friction's flips where a swinging cart reverses and the model's error share are not
    # a push; nor is the record's typical misfit
    allowance = np.zeros(m.n_samples) if model.push_allowance is None else model.push_allowance
    v = m.v[:, model.column]
    if pulled_by_free:
        # nor the creep of a cart that stops while another free cart still pulls it: below the
        # friction regressor's smoothing speed its tanh(v / v_s) falls short of the kinetic
        # level (and the force may be anywhere up to the static one), that share of the stick
        # allowance (red team two_cart_coulomb_y12 seed 1110: 0.6 mm at 5-14 mm/s against
        # v_s = 23 mm/s, the residual at the kinetic level, had ended the window as a touch
        # 0.4 s before the carts stopped). A held cart's pull is a hand's: no such allowance.
        creep = STICK_ALLOWANCE * abs(model.dry) * (1.0 - np.abs(np.tanh(v / model.v_smooth)))
        allowance = np.maximum(allowance, creep)
    excess = np.maximum(np.abs(model.residual) - allowance, 0.0)
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
