"""Where a release happened: the dating of a release the detector found. Pure.

`daq.detector` finds releases (a fast departure from a hold, or a free ringing); this module
places their instant on the samples it keeps (`t` (N,) s, `pos` (N, C) m, oldest first).

A hand is a force on the cart. On the real ECP-210 hand releases (the shared records) the
hand's force per unit mass, measured as the acceleration left after the fitted free motion,
rises over 60-150 ms to 10-19 m/s², declines, and is still 3-9 m/s² (0.2-1.2 times the
spring's pull) when the hand lets go; it is gone within ~10 ms. So the release is dated
as the end of a hand force joined to the free response:

- from a still hold (`daq.hold_dating`, the fast path): the hand held the cart against the
  spring; at t0 that force ends and the spring's starts the motion, `y = x0 + Σ c_k max(t -
  t0, 0)^k`, or with the spring known from a ringing its response from rest (`daq.onset`);
- a ringing (`date_ringing`): the free response `f` (a damped sinusoid about a drifting
  centre with dry friction, `daq.ringing.FreeFit`) is fitted a period on and slid back while
  the data keep following it (`daq.ringing.slide_back`); around where it stops, the joined
  model of `daq.joined` places t0 (`date_release`: `f` plus the cart's response to a hand
  force that ends at t0; for a cart of a free pair, `date_pair`, with `f` driven by the
  other cart's measured motion). From a still hold the onset fit is kept unless the free
  response clearly begins later (more than two samples) and the onset starts the cart
  slower than the spring's pull at the hold (`let_go_at_once`: a hand that lets go
  gradually) or from its rest (`from_afar`: a flick's push).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from daq.detector_events import DetectorSettings, Rejected, Released, Samples
from daq.driven import DRIVEN_EXPLAINS, DRIVEN_FIT, PAIR_FLOOR, fits_across, no_hand_before, pair_release, still_free
from daq.held import moving_carts
from daq.hold_dating import date_hold_release
from daq.joined import HAND_TERMS, PAIR_HAND_TERMS, ReleaseDate, date_pair, date_release
from daq.ringing import FreeFit, Turn, centre_of, fit_free, motion_sign, slide_back, spring_of, swings

Array = npt.NDArray[np.float64]
# why a ringing that the other cart's measured motion drives is no release
DRIVEN_BY_OTHER = "ringing: the other cart moved this one (no hand on it)"
FREE_MIN_SAMPLES = 16
# a ringing's free response is judged against its own RMS misfit, taken at least this share of its
# swing |C - B| (a few samples' RMS is a poor yardstick at low rates; `daq.driven.PAIR_FLOOR` is
# a free pair's)
RING_FLOOR = 0.0003
# a hold's onset that starts the cart at this share of the spring's pull there or more was a
# hand let go at once (`let_go_at_once`): a hand that eases off starts it slower
AT_ONCE = 0.7


def others_swing(s: Samples, channel: int, t0_s: float, held_ratio: float) -> bool:
    """True when a channel other than `channel` swung like it since `t0_s` (held or free by
    `daq.held.moving_carts`, the rule the run's metadata states)."""
    after = s.pos[s.t >= t0_s]
    spans = [float(v) for v in np.ptp(after, axis=0)] if after.size else [0.0] * s.pos.shape[1]
    moving = moving_carts(channel + 1, spans, held_ratio)
    return moving is not None and len(moving) > 1


def hand_took(s: Samples, channels: list[int], turns: tuple[Turn, Turn, Turn], min_swing_m: float,
              held_ratio: float) -> bool:
    """Whether a hand took one of `channels` over `s` (the samples since turn A): it no longer
    moves as its free response driven by the other carts' measured motion (`daq.driven.still_free`;
    a cart of a free pair, one that others swing with as `daq.held` tells, at another ω than its
    own ringing's)."""
    paired = len(channels) > 1 or others_swing(s, channels[0], turns[0].t_s, held_ratio)
    return not still_free(s.t, s.pos, channels, spring_of(turns), min_swing_m, paired)


# --- a ringing ------------------------------------------------------------------------------
def free_span(half_s: float, step_s: float) -> float:
    """How long the free response is fitted (s): three quarters of a period, and at least
    `FREE_MIN_SAMPLES` samples (a stiff spring at 50 Hz has 4 samples a half-period: six samples
    for the free model's seven unknowns fit exactly, and the slide-back then stops at the first
    sample more, a turn, a half-period late)."""
    return max(1.5 * half_s, FREE_MIN_SAMPLES * step_s)


def _free_after(t: Array, y: Array, signs: Array, t_from: float, span: float, sigma0: float,
                half: float) -> tuple[FreeFit | None, Array]:
    """The free response fitted on [t_from, t_from + span], with the dry friction of the motion's
    `signs` unless it gains little, and the signs it was fitted with (zero without friction)."""
    window = (t >= t_from) & (t <= t_from + span)
    free = fit_free(t[window], y[window], signs[window], sigma0, math.pi / half)
    linear = fit_free(t[window], y[window], 0.0 * signs[window], sigma0, math.pi / half)
    if linear is not None and (free is None or free.rms_m > 0.7 * linear.rms_m):
        return linear, 0.0 * signs     # no dry friction to speak of: keep the model lean
    return free, signs


def date_ringing(s: Samples, t_now: float, channel: int, turns: tuple[Turn, Turn, Turn],
                 settings: DetectorSettings, first_t: float) -> Released | Rejected:
    """Fit the free response after B, slide the fit back while it holds; date where it began."""
    a, b, c = turns
    half = 0.5 * (c.t_s - a.t_s)
    s2 = abs(c.x_m - b.x_m)
    sigma0 = spring_of(turns)[0]
    floor = RING_FLOOR * s2
    t, y = s.t, s.pos[:, channel]
    span = free_span(half, float(np.median(np.diff(t[-20:]))))
    signs = motion_sign(t, y)
    t_from = b.t_s + 0.25 * half
    free, vs = _free_after(t, y, signs, t_from, span, sigma0, half)
    # a window the stream's end cuts (a release cut by the record's end, dated as it ends) starts
    # earlier, from as soon after A as it is free, so that it holds its span, when the free
    # response fits it as the slide-back would (a free pair's two modes do not: kept from B
    # then): a third of a period after B set ω 9 % off and a misfit yardstick a third of the
    # whole window's, and the slide-back stopped at B, 0.4 s after the let-go
    early = max(float(t[-1]) - span, a.t_s + 0.25 * half)
    if early < t_from and free is not None:
        whole, whole_vs = _free_after(t, y, signs, early, span, sigma0, half)
        if whole is not None and whole.rms_m <= 1.5 * max(free.rms_m, floor):
            t_from, free, vs = early, whole, whole_vs
    window = (t >= t_from) & (t <= t_from + span)
    if free is None:
        return Rejected(t_now, 0.0, "ringing: fit failed")
    paired = others_swing(s, channel, t_from, settings.held_ratio)
    lone_misfit = free.rms_m > settings.ring_fit_max_rel * s2
    if lone_misfit and not paired:
        return Rejected(t_now, 0.0, f"ringing: not a free response (fit rms {free.rms_m:.2g} m "
                                    f"for a swing of {s2:.2g} m)")
    # (the ringing swings by at least `ring_min_swing_m`: its window is judged whatever it spans)
    if not still_free(t[window], s.pos[window], [channel], (sigma0, math.pi / half), 0.0, paired):
        # a hand in the window (a cart caught as it swung and moved on): judged when it is let go
        return Rejected(t_now, 0.0, "ringing: not a free response (a hand moved the cart in it)")
    limit = max(float(t[0]), a.t_s - 4.0 * half)
    too_early = max(half, 2.0 * settings.fit_post_s)
    if lone_misfit:
        # a free pair whose modes lie far apart (a stiff coupling) swings as no one damped
        # sinusoid (testkit 11061: 8 % of the swing), but as its free response driven by the
        # other cart's measured motion (`still_free` above): dated on that alone
        start = _pair_start(s, t_now, channel, signs, t_from, t_from, half, (sigma0, math.pi / half),
                            PAIR_FLOOR * s2, limit, first_t + too_early, settings)
        if start is None:
            return Rejected(t_now, 0.0, f"ringing: not a free response (fit rms {free.rms_m:.2g} m for a "
                                        f"swing of {s2:.2g} m, nor driven by the other cart from a release in view)")
        return start if not isinstance(start, float) else released_at(s, start, channel, 0.0, t_now, settings.fire_m)
    t_coarse, free = slide_back(t, y, vs, t_from, span, half, free, limit, floor)
    # a release shows the hand before it: within a half-period of the stream's start the data
    # cannot tell a release from a swing that was going on (a record that starts in motion);
    # judged on the slid-back start and again on the fine instant (it may lie before it)
    date = None
    if t_coarse - half / 8.0 >= limit and t_coarse - first_t >= too_early:
        # a cart of a free pair: the straight hand force, as its own date's (`date_pair`); the
        # curve moved a cut free pair's date where its driven fit held across (testkit 11333 at
        # 50 Hz, lost as "driven by the other")
        date = date_release(t, y, vs, free, t_coarse, half, hand_terms=PAIR_HAND_TERMS if paired else HAND_TERMS)
        if date is None:
            return Rejected(t_now, 0.0, "ringing: release fit failed")
    if date is None or date.t0_s - first_t < too_early:
        return Rejected(t_now, 0.0, "ringing: in motion since the stream started (no release seen)"
                        if t[0] <= first_t else "ringing: no release in view (it rang before)")
    ref = max(free.rms_m, floor)
    others = np.delete(s.pos, channel, axis=1)
    spring = (date.free.sigma, date.free.omega)
    driven, alone = fits_across(t, y, signs, others, date.t0_s, half, date.free.t_ref, spring)
    if not paired and fits_across(t, y, signs, others, date.t0_s, 2.0 * half, date.free.t_ref,
                                  spring)[0] <= DRIVEN_FIT * ref:
        # a cart whose free response, driven by the other's measured motion, holds from a period
        # before the date on was in no hand there: it rang on while a hand moved the other cart
        # and then held it (testkit 9009: recorded at the end of that move). A let-go misses by
        # far more there (the hold or the push before it: real 2025 releases 57-150 times the
        # ringing's residual, testkit students 200 and more; that move, 0.7)
        return Rejected(t_now, 0.0, DRIVEN_BY_OTHER)
    # two free carts each drive the other: the hand let go where that stops holding
    start = (_pair_start(s, t_now, channel, signs, date.t0_s, t_from, half, spring, PAIR_FLOOR * s2, limit,
                         first_t + too_early, settings) if paired else None)
    if isinstance(start, (Released, Rejected)):
        return start
    driven_only = driven <= DRIVEN_FIT * ref and driven <= DRIVEN_EXPLAINS * alone
    if driven_only and start is None:
        return Rejected(t_now, 0.0, DRIVEN_BY_OTHER)
    if start is not None:
        # a cart of a free pair swings as its free response driven by the other's, and is dated
        # on it (`date_pair`; the lone damped sinusoid misses the pair's other mode: free pairs'
        # flicks dated 10-25 ms early at 1 kHz, and 0.27-0.65 s late where its slide stopped at
        # that mode). Found half a half-period further back than the lone date, the lone fit's
        # check that no hand acted before it is not this date's
        if driven_only or start < date.t0_s - half / 2.0:
            alone = math.inf
        date = ReleaseDate(start, date.accel_m_s2, date.free)
    if alone <= DRIVEN_FIT * ref and date.t0_s - 2.0 * half < first_t:
        # no hand in the half-period before t0, and nothing of the stream before that half-period
        return Rejected(t_now, 0.0, "ringing: in motion since the stream started (no hand seen)")
    return released_at(s, date.t0_s, channel, date.accel_m_s2, t_now, settings.fire_m)


def _pair_start(s: Samples, t_now: float, channel: int, signs: Array, t0_s: float, t_from: float, half: float,
                spring: tuple[float, float], floor_m: float, limit: float, t_first: float,
                settings: DetectorSettings) -> float | Released | Rejected | None:
    """The release of `channel`, a cart of a free pair (its motion's `signs`, `motion_sign`),
    where its free response driven by the other's measured motion, slid back from `t0_s`
    (`pair_release`), stops holding: finely dated (`date_pair`). When the slide reaches
    `limit`, the partner's release (`partner_release`) or a rejection; a rejection when the
    pair's own model holds across that date (no hand); None when the driven fit fails or the
    date lies before `t_first`."""
    t, y = s.t, s.pos[:, channel]
    others = np.delete(s.pos, channel, axis=1)
    pair = pair_release(t, y, signs, others, t0_s, half, spring, floor_m, limit)
    if pair is None:
        return None
    if pair[0] == -math.inf:
        # driven back as far as it was searched: the cart of the pair the hand never touched,
        # and its partner the one it let go
        # (its release, confirmed by the other's ringing, may lie further back than this
        # ringing's search: as far as a release may be confirmed after it)
        reach = min(limit, max(float(t[0]), t_now - settings.first_release_confirm_s))
        partner = partner_release(s, t_now, channel, t_from, half, reach, t_first, settings)
        return partner or Rejected(t_now, 0.0, DRIVEN_BY_OTHER)
    if pair[0] < t_first:
        return None
    start = date_pair(t, y, signs, others, pair[0], half, pair[1])
    if no_hand_before(t, y, signs, others, start, half, pair[1], floor_m):
        # where the slide-back stopped, the pair's own model broke (a cart that sticks and
        # slips under dry friction), not a hand: the pair rang on across it
        return Rejected(t_now, 0.0, "ringing: the pair's own motion holds across its slide-back's end (no hand)")
    return start


def released_at(s: Samples, t0_s: float, channel: int, accel_m_s2: float, t_now: float, fire_m: float) -> Released:
    """A release of `channel` dated at `t0_s`, confirmed at `t_now`: its trigger where the cart
    first moved `fire_m` from where it was at t0, its hold the positions at the sample before."""
    t, y = s.t, s.pos[:, channel]
    k0 = int(np.searchsorted(t, t0_s))
    away = np.flatnonzero(np.abs(y[k0:] - y[min(k0, y.size - 1)]) > fire_m)
    trigger = float(t[k0 + int(away[0])]) if away.size else t_now
    return Released(t0_s, trigger, t_now, channel, accel_m_s2, tuple(float(v) for v in s.pos[max(0, k0 - 1)]))


def partner_release(s: Samples, t_now: float, channel: int, t0_s: float, half_s: float, t_limit: float,
                    t_first: float, settings: DetectorSettings) -> Released | None:
    """The release of the cart that swings freely with `channel` (a free pair whose other cart
    the hand never touched, so its ringing is driven back as far as it is searched): the
    partner's own driven free response slid back from the ringing's window (from `t0_s`, 1.5
    half-periods) to where a hand held it (`pair_release`, no further back than `t_limit`, and
    finely dated by `date_pair`), when from there it swings out and back (`swings`, by
    `ring_min_swing_m` at least) within three half-periods and moves as that free response
    over its first period (`still_free`: a hand may hold it, or push it smoothly away, while
    its partner rings). None when there is no such partner or no release in view from
    `t_first` on. Its `accel_m_s2` is 0: no onset is fitted."""
    if s.pos.shape[1] != 2:
        return None
    partner = 1 - channel
    t, y = s.t, s.pos[:, partner]
    window = (t >= t0_s) & (t <= t0_s + 1.5 * half_s)
    span = float(np.ptp(y[window])) if np.any(window) else 0.0
    if np.count_nonzero(window) < 12 or span < settings.ring_min_swing_m:
        return None
    spring = (0.0, math.pi / half_s)
    others = np.delete(s.pos, partner, axis=1)
    signs = motion_sign(t, y)
    pair = pair_release(t, y, signs, others, t0_s, half_s, spring, PAIR_FLOOR * span, t_limit)
    if pair is None or not math.isfinite(pair[0]) or pair[0] < t_first:
        return None
    start = date_pair(t, y, signs, others, pair[0], half_s, pair[1])
    # judged from the release on (a hold before it is no hand on the free cart): out and back
    # within three half-periods (a pair's beating may flatten its first swing), free over its
    # first period (a back-to-back release may take it soon after)
    swung = (t >= start) & (t <= start + 3.0 * half_s)
    free = (t >= start) & (t <= start + 2.0 * math.pi / pair[1][1])
    if not swings(t[swung], y[swung]) or not still_free(t[free], s.pos[free], [partner], spring, 0.0, True):
        return None
    if no_hand_before(t, y, signs, others, start, half_s, pair[1], PAIR_FLOOR * span):
        return None     # where the slide-back stopped, the pair's own model broke: no hand
    return released_at(s, start, partner, 0.0, t_now, settings.fire_m)


def date_ringing_release(s: Samples, t_now: float, channel: int, turns: tuple[Turn, Turn, Turn],
                         settings: DetectorSettings, first_t: float) -> Released | Rejected:
    """Date a ringing: from a still hold by the onset fit unless the free response clearly began
    later (a hand that lets go gradually), or where the free response begins."""
    free = date_ringing(s, t_now, channel, turns, settings, first_t)
    spring = spring_of(turns)
    hold = date_hold_release(s, t_now, turns[0], settings, spring)
    if hold is None:
        return free
    after = s.t >= hold.t_release_s
    if (not swings(s.t[after], s.pos[after, hold.channel])
            or (isinstance(free, Rejected) and free.reason == DRIVEN_BY_OTHER and hold.channel == channel)):
        # a hand pulled a cart and holds it: the other, coupled to it, left the hold with it
        # and rings about its new rest, driven by it (when it left the hold further than the
        # pulled cart, the onset fit took it for the released one)
        return free
    if isinstance(free, Released) and free.channel != hold.channel:
        # the free response's cart is the released one (a free pair's partner may leave the
        # hold further, driven: its onset is the push of a flick on the other cart)
        hold = date_hold_release(s, t_now, turns[0], settings, spring, free.channel)
        if hold is None:
            return free
    if not isinstance(free, Released):
        return hold
    # a hand that lets go gradually, or a flick's push from rest: the motion starts before the
    # free response does, and slower than the spring's pull at the hold, or from the cart's rest
    # (a hand let go at once starts it at that pull)
    late = free.t_release_s - hold.t_release_s > max(2.0 * float(np.median(np.diff(s.t[-20:]))), 0.005)
    if others_swing(s, hold.channel, hold.t_release_s, settings.held_ratio):
        # two carts ring together: the onset stands unless it left the rest (the real motor
        # pulses on a free pair start 0.23-0.32 s before their free response is found)
        return free if late and hold.channel == channel and not from_afar(hold, turns) else hold
    return free if late and not (from_afar(hold, turns) and let_go_at_once(hold, turns)) else hold


def from_afar(hold: Released, turns: tuple[Turn, Turn, Turn]) -> bool:
    """Whether the hold lay at least a quarter of the ringing's swing |C - B| from its centre
    (`centre_of`): the cart was held against the spring, or a force (a motor's step) moved its
    rest away. A hold at the centre is the cart's rest, and the motion that left it a hand's
    push (a flick from rest), however fast: no spring's pull to compare its start with (free
    pairs' flicks from rest were dated at the push's start, 0.1-0.2 s early)."""
    _, b, c = turns
    return abs(hold.hold_pos[hold.channel] - centre_of(turns)) >= 0.25 * abs(c.x_m - b.x_m)


def let_go_at_once(hold: Released, turns: tuple[Turn, Turn, Turn]) -> bool:
    """Whether the hold's onset starts the cart at the spring's pull there: its acceleration at
    least `AT_ONCE` of ω² times the hold's distance from the ringing's centre ((A + 2B + C)/4,
    ω from the turns). A free response that begins later then misses a mode the damped
    sinusoid lacks, not a hand that eased off (red team `coupled_span` 1500: a pinned 0.75 kg
    cart beside a 2.8 kg one, 1.34 of the pull at the onset, the free response's start 242 ms
    late; the red team's hold releases start at 0.98-1.22 of it)."""
    omega = spring_of(turns)[1]
    return hold.accel_m_s2 >= AT_ONCE * omega ** 2 * abs(hold.hold_pos[hold.channel] - centre_of(turns))
