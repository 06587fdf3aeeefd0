"""A release from a still hold, dated by the onset fit on the detector's kept samples. Pure.

The hand held the cart against the spring; at t0 that force ends and the spring's starts the
motion, `y = x0 + Σ c_k max(t - t0, 0)^k`, or with the spring known (from the pull and the start
acceleration, or from a ringing) its response from rest (`daq.onset`); the release is then dated
again with the hand's own motion (its tremor) on both sides of t0. `daq.detector` uses it on
the fast path; `daq.release_dating` for a ringing that began from a hold.
"""

from __future__ import annotations

import math

import numpy as np

from daq.detector_events import DetectorSettings, Released, Samples
from daq.onset import OnsetFit, fit_onset
from daq.ringing import Turn

# a hold's release is dated again with the hand's own motion from this long before the first
# date: a quarter of a 7-12 Hz tremor's cycle, over which a quadratic follows it
HAND_LOOKBACK_S = 0.025
# ω from a pull's start acceleration, refitted this many times (`spring_of_pull`; the second
# pass moves a 40 rad/s cart's date by 0.1 ms at 1 kHz, a third by less than 0.02)
PULL_SPRING_PASSES = 2


def fit_onset_at(s: Samples, channel: int, hold: tuple[float, ...], trigger_t: float,
                 settings: DetectorSettings, spring: tuple[float, float] | None = None,
                 onset_t: float | None = None) -> OnsetFit | None:
    """The onset fit on the hold before `trigger_t` and the window the live decision saw.

    With `onset_t` (a first date) the release is dated again with the hand's own motion
    (`fit_onset`'s `hand_motion`), from `HAND_LOOKBACK_S` before that date."""
    times = s.t
    before = np.flatnonzero(times < trigger_t)
    if before.size < 2:
        return None
    lookback = settings.fit_lookback_s if onset_t is None else trigger_t - onset_t + HAND_LOOKBACK_S
    n_back = max(settings.fit_min_lookback_samples,
                 int(np.count_nonzero(times[before] >= trigger_t - lookback)))
    first = int(before[max(0, before.size - n_back)])
    after = np.flatnonzero(times >= trigger_t)
    # the window the live decision saw: fit_post_s and fit_min_post_samples past the trigger
    n_post = max(settings.fit_min_post_samples + 1,
                 int(np.count_nonzero(times[after] <= trigger_t + settings.fit_post_s)))
    last = int(after[min(after.size, n_post) - 1]) + 1 if after.size else len(times)
    t = times[first:last] - trigger_t
    y = s.pos[first:last, channel] - hold[channel]
    return fit_onset(t, y, settings.fit_powers, trigger_offset_s=trigger_t, spring=spring,
                     hand_motion=onset_t is not None)


def spring_of_pull(s: Samples, channel: int, hold: tuple[float, ...], trigger_t: float, fit: OnsetFit,
                   pull_m: float, settings: DetectorSettings) -> tuple[OnsetFit, tuple[float, float] | None]:
    """The onset fit of a release from a hold pulled `pull_m` from the cart's rest, with the
    spring's motion from rest (σ 0, ω² = a / |pull|) in place of τ², τ³ when it fits as well.

    Over the fitted window a stiff spring turns (ωτ ≈ 2 at 40 rad/s and 50 ms) and τ², τ³
    date the release late (1.1 ms for a 40 rad/s cart at 1 kHz); ω from the fitted start
    acceleration and the pull, refitted `PULL_SPRING_PASSES` times, follows it. Dry friction
    lowers that acceleration a little (ω a little low), a wrong rest a lot: the spring is kept
    only when its fit is no worse than the polynomial's. Returns (the fit, the spring or None).
    """
    best, spring, current = fit, None, fit
    if abs(pull_m) <= settings.rest_margin_m:
        return best, spring
    for _ in range(PULL_SPRING_PASSES):
        if current.accel_m_s2 == 0.0:
            break
        omega = math.sqrt(abs(current.accel_m_s2) / abs(pull_m))
        again = fit_onset_at(s, channel, hold, trigger_t, settings, (0.0, omega))
        if again is None:
            break
        current = again
        if again.rms_m <= fit.rms_m:
            best, spring = again, (0.0, omega)
    return best, spring


def redate_hold(s: Samples, channel: int, hold: tuple[float, ...], trigger_t: float, fit: OnsetFit,
                settings: DetectorSettings, spring: tuple[float, float] | None = None) -> float:
    """The instant (s) of a release from a still hold that `fit` dated, dated again with the
    hand's own motion (its tremor) on both sides of t0; `fit`'s where that fit fails."""
    again = fit_onset_at(s, channel, hold, trigger_t, settings, spring, onset_t=fit.t0_s)
    return fit.t0_s if again is None else again.t0_s


def date_hold_release(s: Samples, t_now: float, a: Turn, settings: DetectorSettings,
                      spring: tuple[float, float] | None = None, channel: int | None = None) -> Released | None:
    """The ringing began from a hold (still before turn A): date it by the onset fit, or None.

    The cart that moved most from the hold is the released one (two carts may both ring) unless
    `channel` is given; only it must have been still: the other cart, held by a hand, may
    wander by millimetres. With `spring` (σ, ω of the ringing) the onset is the spring's motion
    from rest (`daq.onset`).
    """
    plateau_mask = (s.t >= a.t_s - settings.still_s) & (s.t <= a.t_s)
    plateau = s.pos[plateau_mask]
    if len(plateau) < settings.fit_min_lookback_samples or s.t[0] > a.t_s - settings.still_s:
        return None
    hold = tuple(float(v) for v in plateau.mean(axis=0))
    after_mask = s.t > a.t_s
    after = s.pos[after_mask]
    if channel is None:
        channel = int(np.argmax(np.max(np.abs(after - np.array(hold)), axis=0)))
    column = plateau[:, channel]
    if float(column.max() - column.min()) > 2.0 * settings.still_band_m:
        return None
    away = np.flatnonzero(np.abs(after[:, channel] - hold[channel]) > settings.fire_m)
    if away.size == 0:
        return None
    trigger = float(s.t[after_mask][away[0]])
    fit = fit_onset_at(s, channel, hold, trigger, settings, spring)
    if fit is None:
        return None
    return Released(redate_hold(s, channel, hold, trigger, fit, settings, spring), trigger, t_now, channel,
                    abs(fit.accel_m_s2), hold)
