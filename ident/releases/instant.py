"""The release instant: where the hand's force on the pulled cart has ended.

The hand episodes (`hand`) come from accelerations smoothed over a tenth of a period, which
blurs where a force ends by half that window. Here the same free equation of motion is
evaluated with derivatives over a window 2.5 times shorter (a 25th of a period, at least
5 samples, wider where the reading noise would bury the hand's force: `_fine_window`), which
is noisier but sharp, and the release is the sample after the last one,
after the episode's peak force and before the first stretch of T/12 where it stays
below the limit (that the force does not leave by coming back over twice the limit),
where that finer residual |r| exceeds

    max(FRACTION_OF_PEAK · max|r| over the episode, NOISE_SIGMAS · its robust std in the
        free period that follows):

a hand lets go by ramping its force down, and the free response begins where the force is
down to the noise. The crossing is taken between samples, less the delay the smoothing
adds to a force that drops at once from the level it had just before (`smoothing_delay`,
computed from the filter itself). The residual takes the held carts' positions as measured
and the cart's stiffness refitted on the free period after the episode (`_local_stiffness`).
No I/O.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.releases.hand import HAND_SIGMAS, FreeModel, regressors
from ident.releases.motion import Motion, accel_noise_gain, smoothed_noise

FINE_FRACTION = 1.0 / 25.0
#: ... widened (up to the coarse window) until its limit from white reading noise,
#: NOISE_SIGMAS · noise · gain, is at most this share of the hand's peak force (`_fine_window`)
FINE_NOISE_SHARE = 0.2
FRACTION_OF_PEAK = 0.02
NOISE_SIGMAS = 4.0
#: The force has ended when the residual stays below the limit this fraction of a period.
QUIET_FRACTION = 1.0 / 12.0
#: ... unless it comes back after that stretch above this multiple of the limit: the hand's
#: force passed through zero (a flick braked to its path's end and held there) and it is
#: still there (`release_instant`); a flick whose push faded and that the hand held again at
#: its path's end, at 1.55 limits, had been dated at the push's end, 47 ms (8 samples) early
#: (red team `coulomb+quantization` 10701, 178 Hz)
RETURN_FACTOR = 1.5
#: ... and a weak blip (at most that multiple) after a quiet gap of more than the fine window
#: (the filter's whole width: no smear of the hand's force reaches that far) is not the hand
#: (`_without_blips`)
BLIP_GAP = 1.0
#: The local stiffness is refitted on at least this many free samples (`_local_stiffness`).
MIN_LOCAL_SAMPLES = 10
#: ... and a curved spring (x², x³) on at least this many, when it leaves at most this share of
#: the straight refit's squared residual (`_local_stiffness`).
MIN_CURVED_SAMPLES = 40
CURVED_GAIN = 0.5


def release_instant(m: Motion, model: FreeModel, first: int, last: int) -> float:
    """The release time (s, on `m.t`) after the hand episode [first, last] of `model.column`."""
    from scipy.signal import savgol_filter  # deferred: keeps `import ident` fast
    period_n = m.samples(m.period_s)
    window = _fine_window(m, model, first, last)
    lo = max(0, first - window)
    hi = min(m.n_samples, last + 2 * period_n)
    if hi - lo <= window:
        return float(m.t[min(last + 1, m.n_samples - 1)])
    part = m.y[lo:hi]
    fine = Motion(m.t[lo:hi], part, savgol_filter(part, window, 3, axis=0),
                  savgol_filter(part, window, 3, deriv=1, delta=m.dt, axis=0),
                  savgol_filter(part, window, 3, deriv=2, delta=m.dt, axis=0),
                  m.dt, m.period_s, m.noise_m, window, smoothed_noise(m.noise_m, window))
    extra = model.extra if model.extra is not None else np.zeros(0)
    coef = np.concatenate([model.stiffness, [model.viscous, model.dry, model.offset], extra])
    # the held carts' positions as measured: the fit takes a held cart's period average (to
    # keep its weak following of this cart apart from x_j), which blurs its step at the
    # release over a period
    basis = regressors(fine, model.column, model.others, model.v_smooth, (),
                       model.speed if extra.size else None,
                       None if model.hidden is None else model.hidden[lo:hi])
    resid = _local_stiffness(fine.a[:, model.column] - basis @ coef, basis[:, 0],
                             last - lo + max(m.window, period_n // 8), min(hi, last + period_n) - lo,
                             _curved_from(model, period_n))
    after = resid[last + m.samples(m.period_s / 4) - lo:last + period_n - lo]
    # about its median: a held cart moved elsewhere offsets the residual for good
    level = float(np.median(after)) if after.size else 0.0
    noise = float(np.median(np.abs(after - level))) / 0.6745 if after.size else 0.0
    resid = resid - level
    peak = float(np.max(np.abs(resid[first - lo:last + 1 - lo])))
    limit = max(FRACTION_OF_PEAK * peak, NOISE_SIGMAS * noise)
    seg = np.abs(resid[first - lo:hi - lo])
    # from the peak, but not earlier than two smoothing windows before the episode's end (the
    # coarse residual sees the hand's force half a window after it ends): a hand that grabs
    # a ringing cart and pulls it slowly may push with almost no force for a while after the
    # grab, which is not where it lets go; nor later than a window after the episode's end
    # (the fine residual's noise is not a hand)
    peak_at = int(np.argmax(seg[:last + 1 - first]))
    quiet = m.samples(m.period_s * QUIET_FRACTION)
    late = min(seg.size, last - first + m.window + 1)
    loud = _loud(seg, limit, max(peak_at, last - first - 2 * m.window), late, m.uneven_stamps)
    if not loud.size:
        loud = _loud(seg, limit, peak_at, late, m.uneven_stamps)
    loud = _without_blips(loud, seg, RETURN_FACTOR * limit, BLIP_GAP * window)
    # the first gap between loud samples that lasts a quiet stretch: the force has ended,
    # unless it comes back strong after it (a braked flick held at its path's end: red team
    # quantization 1500, 176 Hz, dated 83 ms early at the brake's zero crossing)
    gaps = np.flatnonzero(np.diff(np.concatenate([loud, [seg.size + quiet]])) > quiet)
    if not loud.size:
        return float(m.t[min(last + 1, m.n_samples - 1)])
    g = 0
    while g + 1 < gaps.size and np.max(seg[loud[gaps[g] + 1]:loud[gaps[g + 1]] + 1]) > RETURN_FACTOR * limit:
        g += 1
    k = int(loud[gaps[g]])
    if k + 1 >= seg.size:
        return float(m.t[first + k])
    # where |r| crosses the limit, between samples, less the smoothing's delay for a force
    # that drops at once from the level it had just before
    before = float(np.max(seg[max(0, k - window):k + 1]))
    # (within the sample step: the next sample may be loud again beyond the searched span)
    crossing = k + min(1.0, (seg[k] - limit) / max(seg[k] - seg[k + 1], 1e-300))
    release = first + crossing - smoothing_delay(window, limit / before)
    if release < last - m.window and _coarse_hand_after(m, model, int(np.ceil(release)) + m.window, last,
                                                        period_n):
        # the coarse residual saw the hand a window later: its last force was below the fine
        # residual's limit (a force that passed through zero and came back weak, or a free
        # response whose unmodelled effects make the fine residual noisy)
        release = _coarse_end(m, model, last)
    return float(m.t[0] + np.clip(release, first, m.n_samples - 1) * m.dt)


def _fine_window(m: Motion, model: FreeModel, first: int, last: int) -> int:
    """The fine residual's window (samples, odd): a 25th of a period (at least 5 samples),
    widened two samples at a time, up to the coarse window, while the reading noise alone
    would put its limit (`NOISE_SIGMAS` of that noise through the filter) above
    `FINE_NOISE_SHARE` of the hand's peak force in the episode [first, last] (the coarse
    residual's). At a 25th of a period (9 samples) a flick read with 0.11 mm of noise at
    976 Hz had 12 m/s² of noise per width, a limit of 47 m/s² over a hand that peaked at 30:
    its release was dated 23 samples early, where the noise last peaked, and the diagnosis
    took the hand for a 17.6 Hz mode (testkit.effects coupled_mode, seed 1642837041); over
    21 samples, 2.4 samples early and the true 9.1 Hz mode."""
    window = max(5, 2 * round(FINE_FRACTION * m.samples(m.period_s) / 2) + 1)
    peak = float(np.max(_coarse_force(model)[first:last + 1]))
    noise = float(m.noise_m[model.column])
    while window + 2 <= m.window and NOISE_SIGMAS * noise * accel_noise_gain(window, m.dt) > FINE_NOISE_SHARE * peak:
        window += 2
    return window


def _local_stiffness(resid: NDArray[np.float64], minus_x: NDArray[np.float64], a: int,
                     b: int, curved_from: int | None = None) -> NDArray[np.float64]:
    """`resid` less the stiffness and offset refitted on the free stretch [a, b) (`minus_x`
    the regressor -x_j). The free model is fitted on the whole record, so its stiffness is
    a few per cent off at a large swing, and the weak following of a held cart, now taken as
    measured, is in no coefficient: right after a hold's let-go either is a few per cent of
    the hold's force, above the limit. The stretch starts a coarse window (or an eighth of a
    period) after the episode, clear of the hand. With `curved_from` and a stretch that long
    (half a period: the swing's whole range), x² and x³ about its mean are refitted too: a
    cubic spring's force departs from any straight line most at the first extreme, right
    after a hold's let-go (a 24 % hardening: 10 % of the hold's force). Not with an unread
    mass (`FreeModel.hidden`): there the curve also took in a one-encoder chain's second
    mode, lowered the noise level read after the episode and dated a two-cart release 9
    samples late (red team two_cart_coulomb_y1 801). And only where the spring is curved: the
    curve kept when it halves the straight refit's squared residual (`CURVED_GAIN`) on at
    least `MIN_CURVED_SAMPLES`; a real 2025 flick read at 45 Hz (a period of 25 samples) was
    dated 40 ms late with any curve taken."""
    if b - a < MIN_LOCAL_SAMPLES:
        return resid
    straight = _refit(resid, [minus_x, np.ones_like(minus_x)], a, b)
    if curved_from is None or b - a < max(curved_from, MIN_CURVED_SAMPLES):
        return straight
    centre = float(np.mean(minus_x[a:b]))
    curved = _refit(resid, [minus_x, np.ones_like(minus_x), (minus_x - centre) ** 2, (minus_x - centre) ** 3], a, b)
    kept = float(np.sum(curved[a:b] ** 2)) < CURVED_GAIN * float(np.sum(straight[a:b] ** 2))
    return curved if kept else straight


def _refit(resid: NDArray[np.float64], columns: list[NDArray[np.float64]], a: int, b: int) -> NDArray[np.float64]:
    """`resid` less its least-squares fit by `columns` on [a, b)."""
    design = np.column_stack(columns)
    coef, *_ = np.linalg.lstsq(design[a:b], resid[a:b], rcond=None)
    out: NDArray[np.float64] = resid - design @ coef
    return out


def _curved_from(model: FreeModel, period_n: int) -> int | None:
    """How long a free stretch `_local_stiffness` refits a curved spring on: half a period,
    or never with an unread mass (see there)."""
    return period_n // 2 if model.hidden is None else None


def _coarse_hand_after(m: Motion, model: FreeModel, start: int, last: int, period_n: int) -> bool:
    """Whether the coarse residual, its stiffness refitted on the free period after the
    episode as the fine one's is (`_local_stiffness`), still exceeds the hand's limit in
    [start, last]: a force there, not the free model's own misfit at the first swing (a
    spring that hardens by a quarter over it: the whole-record fit missed the first
    extreme by more than the limit for 75 ms after a hold's let-go, red team
    cubic_hardening seed 3002)."""
    if start > last:
        return False
    j = model.column
    local = _local_stiffness(model.residual, -m.x[:, j], last + max(m.window, period_n // 8),
                             min(m.n_samples, last + period_n), _curved_from(model, period_n))
    r = np.abs(local - float(np.median(local[~model.hand])))
    return bool(np.any(r[start:last + 1] > _hand_limit(model)[start:last + 1]))


def _hand_limit(model: FreeModel) -> NDArray[np.float64]:
    """The coarse residual's limit for a hand (N,) m/s²: `HAND_SIGMAS` scales plus the allowance."""
    allowance = model.allowance if model.allowance is not None else np.zeros_like(model.residual)
    limit: NDArray[np.float64] = HAND_SIGMAS * model.scale + allowance
    return limit


def _coarse_end(m: Motion, model: FreeModel, last: int) -> float:
    """The release (samples) where the coarse residual |r| crosses the hand's limit after
    the episode's last sample `last`, less the coarse smoothing's delay."""
    r = _coarse_force(model)
    limit = float(_hand_limit(model)[last])
    if last + 1 >= m.n_samples or r[last] <= limit:
        return float(last)
    before = float(np.max(r[max(0, last - m.window):last + 1]))
    crossing = last + min(1.0, (r[last] - limit) / max(r[last] - r[last + 1], 1e-300))
    return crossing - smoothing_delay(m.window, limit / before)


def _coarse_force(model: FreeModel) -> NDArray[np.float64]:
    """|the coarse residual| (N,) m/s² about its median on the free samples: the hand's force."""
    r = model.residual
    return np.asarray(np.abs(r - float(np.median(r[~model.hand]))), dtype=np.float64)


def _loud(seg: NDArray[np.float64], limit: float, lo: int, hi: int, uneven_stamps: bool) -> NDArray[np.intp]:
    """Indices in [lo, hi) where `seg` exceeds `limit`; with uneven stamps (a coarse clock's)
    only beside a neighbour that does too.

    A coarse clock's stamps, up to a step off, misplace a fast cart by up to a millimetre: one
    sample alone above the limit is then that, not the hand (red team ECP-clock holds let go
    at 80-120 m/s², running at 1 m/s within 10 ms, left single samples at 4 noise widths 8 and
    20 ms after the let-go, and were dated there). On an even clock a lone loud sample can be
    the last of a weak push (issue-11 red team, 192 cases: 4 fewer dated within a sample when
    such samples were passed over everywhere)."""
    above = seg > limit
    if uneven_stamps:
        above = above & (np.concatenate([[False], above[:-1]]) | np.concatenate([above[1:], [False]]))
    return np.flatnonzero(above[lo:hi]) + lo


def _without_blips(loud: NDArray[np.intp], seg: NDArray[np.float64], strong: float, gap: float) -> NDArray[np.intp]:
    """`loud` less its runs (consecutive samples) that come more than `gap` samples after the
    last run kept and stay at most `strong`: a weak blip after the force has ended. On a
    coarse clock (the ECP Teensy's 1 and 2 ms steps) a fast cart's misplaced stamp leaves one:
    red team run10 record 2459, a flick held to rest at its extreme and let go at once (a
    9.9 m/s² jump), was dated 30 ms late at a two-sample blip 0.69 over a limit of 0.62,
    23 ms after the force had ended (short of the quiet stretch, T/12 = 30 ms)."""
    if loud.size < 2:
        return loud
    runs = np.split(loud, np.flatnonzero(np.diff(loud) > 1) + 1)
    kept = [runs[0]]
    for run in runs[1:]:
        if run[0] - kept[-1][-1] <= gap or float(np.max(seg[run])) > strong:
            kept.append(run)
    return np.concatenate(kept)


def smoothing_delay(window: int, level: float) -> float:
    """Samples by which the cubic Savitzky–Golay second derivative over `window` samples sees
    an acceleration that drops at once from 1 to 0 fall below `level` (0 < level < 1) after
    the drop: the filter applied to x = ½·min(k - c, 0)² (acceleration 1 before c, 0 after)."""
    from scipy.signal import savgol_filter  # deferred: keeps `import ident` fast
    n = 4 * window + 1
    c = n // 2
    k = np.arange(n, dtype=np.float64)
    acc = savgol_filter(0.5 * np.minimum(k - c, 0.0) ** 2, window, 3, deriv=2)
    level = float(np.clip(level, 0.01, 0.99))
    above = np.flatnonzero(acc[c - window:c + window] > level) + c - window
    j = int(above[-1])
    return float(j + (acc[j] - level) / max(acc[j] - acc[j + 1], 1e-300) - c)
