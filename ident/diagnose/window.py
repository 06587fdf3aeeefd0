"""Where the free response starts: hold level, motion onset, the hand's influence, the release.

A release is not always clean (DESIGN.md): the hand may let go while the cart moves. The
free response is therefore fitted from a window start `t_w` with the state at `t_w` as
parameters. `t_w` is the earliest candidate start, from the motion onset on, whose
first quarter period is predicted by the free response fitted after it (the hand no longer
acts from there on):

    onset: first sample with |y - hold| > max(8 σ_hold, 3 % of the excursion);
    candidates t_w = onset + j·T/24, j = 0..16 (T the oscillation period);
    a one-mode-per-cart fit on [t_w + T/4, t_w + 2.5 T] (rms_fit), extrapolated back over
    [t_w, t_w + T/4] (rms_head);
    t_w = first j with rms_head ≤ 2 rms_fit + 2 σ_hold and rms_head ≤ 3 min_j rms_head + 2 σ_hold
    (else the smallest ratio): the second bound keeps a poor linear fit (strong friction)
    from excusing the hand's push.

The scan only brackets the release: a friction-damped or two-mode record can make it start
periods late. The release is then dated where the hand's force ends (`knot`): a pull-hold
(the cart held still further than `HOLD_AWAY` of its swing from the middle of its swings) by
its acceleration jump at the first motion (`knot.hold_release`); a flick by the C¹ join of a
cubic hand path and the free modes of the scan's fit, searched from the onset to T/4 after
the scan's start (`knot.flick_release`), and again up to the first extreme after the onset
when the join lies well past it (a flick's hand lets go before the cart turns: `_first_turn`);
the window starts there. Only when neither can be fitted, the release is the last zero of
the fitted velocity before `t_w` (within half a period) when the fitted position there is the
held level, else `t_w` itself. A record that starts at a release `ident.releases` dated
(`released_at_start`: `ident diagnose` on a raw record) is not dated again: the window starts
there. The fits start two samples (at least T/200) after `t_w`. Long runs are decimated for
fitting (`MAX_WORK_SAMPLES`). No I/O here.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.knot import Knot, flick_release, hold_release
from ident.errors import IdentValueError
from ident.modal import ModalFit, fit_modes, modal_prediction
from ident.physics.measures import noise_std, spectral_peaks

FloatArray = NDArray[np.float64]

MAX_WORK_SAMPLES = 500
#: The fewest samples after the motion starts: a record the scan dates itself ...
MIN_RUN_SAMPLES = 40
#: ... and a release window dated already (`ident.releases`): five per blocked-CV block
#: (`fitting.BLOCKS`). A 50 Hz cart that friction stops in three cycles rings ~50 samples, and
#: one grabbed again two periods after its let-go ~30.
MIN_RELEASE_SAMPLES = 25
SCAN_STEPS = 17
#: periods of the dominant mode in each window the scan fits
SCAN_PERIODS = 2.5
#: ... and never fewer samples than each of its modal fits needs
MIN_FIT_SAMPLES = 20
#: a hold level this fraction of the swing away from the middle of the swings is a pull-hold
HOLD_AWAY = 0.3


@dataclass(frozen=True)
class Window:
    """The fitted stretch of a run.

    `start` index of t_w in the full run; `decimation` D (every D-th sample is used);
    `hold` (n_out,) held level before the motion; `hold_noise_m` its scatter;
    `release_time_s` the estimated release; `period_s` the dominant period; `tail_cut`: the
    window's still tail was cut (`stretch.still_tail_cut`; sooner where the work grid must resolve
    the fitted modes, `stretch.resolving_decimation`), or a forced record's end
    (`stretch.modes_resolved_cut`); `flick`: how a release the flick's join dated was found
    (the motion's onset and the output it was dated on; `ident.diagnose.redate` dates it again
    on the fitted model), None for any other release.
    """

    start: int
    decimation: int
    hold: FloatArray
    hold_noise_m: float
    release_time_s: float
    period_s: float
    tail_cut: bool = False
    flick: Flick | None = None


@dataclass(frozen=True)
class Flick:
    """A flick's dating: the index of the motion's `onset` and the `output` (column) the hand
    pushed, on which its release was dated (`_flick_any`)."""

    onset: int
    output: int


def hold_level(y: FloatArray) -> tuple[FloatArray, float, int]:
    """Held level (n_out,), its scatter (m) and the index where the motion begins."""
    excursion = np.max(np.abs(y - y[0]), axis=0)
    main = int(np.argmax(excursion))
    if excursion[main] <= 0:
        raise IdentValueError("positions", "a run with motion", "constant positions")
    moved = np.flatnonzero(np.abs(y[:, main] - y[0, main]) > 0.05 * excursion[main])
    first = int(moved[0]) if moved.size else 1
    quiet = y[:max(first - 1, 3)]
    hold = np.median(quiet, axis=0)
    # the one noise estimate (second differences): a slow drift of the hand does not count
    noise = float(noise_std(quiet[:, main])[0]) if quiet.shape[0] >= 8 else 0.0
    dev = np.abs(y[:, main] - hold[main])
    threshold = max(8.0 * noise, 0.03 * float(np.max(dev)))
    onset = int(np.flatnonzero(dev > threshold)[0])
    return hold, noise, onset


def find_window(t: FloatArray, y: FloatArray, carts: int, released_at_start: bool = False) -> Window:
    """Window start, decimation, hold and release time of a run `y` (N, n_out) on `t` (N,).

    `released_at_start`: the record starts where the hand let go (a release's window that
    `ident.releases` dated, as `ident diagnose` on a raw record passes it): the fit starts
    there, after the margin, with no second dating of its own (the scan and the knot below
    dated the 2023 hand steps up to 72 ms later than `ident releases` lists them)."""
    dt = float(t[1] - t[0])
    hold, noise, onset = hold_level(y)
    fewest = MIN_RELEASE_SAMPLES if released_at_start else MIN_RUN_SAMPLES
    if t.shape[0] - onset < fewest:
        raise IdentValueError("run", f"at least {fewest} samples after the motion starts",
                              f"{t.shape[0] - onset}")
    # the modes the scan can fit: at least SCAN_PERIODS periods in the record after the onset
    # (a heavily damped ring released far from rest, then stuck, spreads the power of its
    # hold-to-rest step over the lowest frequencies, where no such mode could be fitted)
    after = y[onset:]
    lowest = max(0.5, 2.0 * np.pi * SCAN_PERIODS / float(t[-1] - t[onset]))
    peaks = spectral_peaks(after - after.mean(axis=0), dt, carts, min_rad_s=lowest)
    period = 2 * np.pi / float(peaks[0])
    if released_at_start:
        return _from(t, 0, period, hold, noise, float(t[0]))
    head = max(2, round(0.25 * period / dt))
    # a few periods, but never fewer samples than a modal fit needs (a 10.8 Hz mode read at
    # 54 Hz has five samples a period: 2.5 periods left no fit, and no window)
    span = max(round(SCAN_PERIODS * period / dt), head + MIN_FIT_SAMPLES)
    step = max(1, round(period / 24 / dt))
    dec = max(1, int(np.ceil(span / 150)))
    scores: list[float] = []
    heads: list[float] = []
    fits = []
    for j in range(SCAN_STEPS):
        a = onset + j * step
        b = min(a + span, t.shape[0])
        if (b - a - head) // dec < MIN_FIT_SAMPLES:   # too few samples left for a modal fit
            break
        fit = fit_modes(t[a + head:b:dec] - t[a], y[a + head:b:dec], peaks)
        rms_fit = float(np.sqrt(fit.sse / fit.residual.size))
        head_err = y[a:a + head] - modal_prediction(fit, t[a:a + head] - t[a])
        rms_head = float(np.sqrt(np.mean(head_err ** 2)))
        fits.append((a, fit))
        heads.append(rms_head)
        scores.append(rms_head / (2.0 * rms_fit + 2.0 * noise + 1e-15))
    if not fits:
        raise IdentValueError("run", f"a free response long enough for a modal fit (a few periods of "
                              f"{period:.3g} s after the motion starts)", f"{t[-1] - t[onset]:.3g} s")
    floor = 3.0 * min(heads) + 2.0 * noise
    ok = [j for j, score in enumerate(scores) if score <= 1.0 and heads[j] <= floor]
    start, fit = fits[ok[0] if ok else int(np.argmin(scores))]
    main = int(np.argmax(np.ptp(y, axis=0)))
    tolerance = max(8.0 * noise, 0.05 * float(np.ptp(y[:, main])))
    release = _last_rest_before(t[start], fit, period, hold, tolerance)
    knot = _hold_release(t, y[:, main], hold[main], onset, period)
    flick = None
    if knot is None:
        # let go while moving: the hand's path before, the free modes after (knot.flick_release)
        knot, flick = _flick_any(t, y, onset, start, period, fit)
    if knot is not None:
        # the free response starts where the hand's force ended
        release = knot.time_s
        start = int(np.searchsorted(t, release))
    return dataclasses.replace(_from(t, start, period, hold, noise, max(release, float(t[0]))), flick=flick)


def _from(t: FloatArray, start: int, period: float, hold: FloatArray, noise: float, release: float) -> Window:
    """The window fitted from a margin after `start` (two samples, at least T/200): the chosen
    start can still hold the hand's last push, which a fast-decaying "mode" would otherwise
    absorb; decimated to at most `MAX_WORK_SAMPLES`."""
    dt = float(t[1] - t[0])
    start = min(start + max(2, round(period / 200 / dt)), max(0, t.shape[0] - MIN_RELEASE_SAMPLES))
    decimation = max(1, int(np.ceil((t.shape[0] - start) / MAX_WORK_SAMPLES)))
    return Window(start, decimation, hold, noise, release, period)


def _flick(t: FloatArray, y: FloatArray, onset: int, start: int, period: float, fit: ModalFit) -> Knot | None:
    """`knot.flick_release` from the onset to T/4 after the scan's start (it may start early or
    late), fitted to T/12 beyond: a longer free stretch would cross velocity reversals, where
    dry friction shifts the free response's centre and drags the join. A join more than half the
    push (onset to extreme) after the first extreme (`_first_turn`) is no flick's let-go: it is
    searched again up to two samples past that extreme (bench seeds 45, 51, 52: joins 9-106
    samples late; a tighter margin moved good joins at a held extreme)."""
    dt, n = float(t[1] - t[0]), t.shape[0]
    turn = _first_turn(y, onset)
    late = min(turn + max(2, (turn - onset) // 2), n - 1)   # half the push after the turn
    knot = None
    for last in (min(start + round(0.25 * period / dt), n - 1), min(turn + 2, n - 1)):
        knot = flick_release(t, y, onset + 1, last, min(last + round(period / 12 / dt), n - 1), fit.freqs, fit.decays)
        if knot is None or knot.time_s <= t[late]:
            return knot
    return knot


def _first_turn(y: FloatArray, onset: int) -> int:
    """The index of the first extreme of `y` (N,) after the onset: where the running extreme of
    the departure, once at least `TURN_FROM` of the record's largest, is followed by a retreat of
    `TURN_BACK` of it (the plateau's end within `TURN_FLAT`). A flick's hand lets go at it or
    before it (a search beyond it, on a two-mode record whose scan started a slow period late,
    joined the hand to the free response 250 ms after the let-go, in the return swing)."""
    d = y[onset:] - y[onset]
    far = TURN_FROM * float(np.max(np.abs(d)))
    x = d * (1.0 if d[int(np.argmax(np.abs(d) >= far))] >= 0 else -1.0)   # the way it first went far
    reach = np.maximum.accumulate(x)
    big = reach >= far
    back = np.flatnonzero(big & (reach - x > TURN_BACK * reach))
    if back.size == 0:
        return y.shape[0] - 1
    top = x[:back[0]]
    # the end of the plateau at it: a hand may hold the cart there a moment before it lets go
    return onset + int(np.flatnonzero(top >= (1.0 - TURN_FLAT) * float(np.max(top)))[-1])


#: a flick's first extreme (`_first_turn`): a running extreme at least this share of the
#: record's largest departure ...
TURN_FROM = 0.3
#: ... that the position then retreats from by this share of it; the turn is the last sample
#: within `TURN_FLAT` of it
TURN_BACK = 0.2
TURN_FLAT = 0.02


def _flick_any(t: FloatArray, y: FloatArray, onset: int, start: int, period: float,
               fit: ModalFit) -> tuple[Knot | None, Flick | None]:
    """The flick's release dated on the cart the hand pushed: the output that moves first (and
    how it was dated, None with the knot when no join could be fitted).

    The hand pushes one cart; only that cart's acceleration jumps when it lets go. A cart
    behind a spring is pulled by a force continuous at the release and starts to move only
    after the pushed one has moved it, so its record has no knot to find and a join fitted to
    it lands wherever its smooth curve fits best (two-cart flicks of `none`, seeds 1036628920
    and 974133204 at bench seed 12: the cart swinging most was the unpushed one, dated 52 and
    17 ms early, and the window's first samples held the hand's push, which a fast-decaying
    8 or 35 Hz "coupled mode" absorbed)."""
    pushed = _pushed(y, onset)
    knot = _flick(t, y[:, pushed], onset, start, period, fit)
    return knot, None if knot is None else Flick(onset, pushed)


def _pushed(y: FloatArray, onset: int) -> int:
    """The output that leaves its hold level first, against one threshold for all (the
    record's `hold_level` rule: 8 hold-noise σ or 3 % of the largest excursion); the one that
    swings most when none moves before it."""
    main = int(np.argmax(np.ptp(y, axis=0)))
    if y.shape[1] == 1:
        return main
    quiet = y[:max(onset - 1, 3)]
    hold = np.median(quiet, axis=0)
    noise = max(float(noise_std(quiet[:, j:j + 1])[0]) if quiet.shape[0] >= 8 else 0.0 for j in range(y.shape[1]))
    dev = np.abs(y - hold[None, :])
    threshold = max(8.0 * noise, 0.03 * float(np.max(dev)))
    firsts = [int(np.argmax(dev[:, j] > threshold)) if np.any(dev[:, j] > threshold) else y.shape[0]
              for j in range(y.shape[1])]
    earliest = min(firsts)
    return main if firsts[main] == earliest else int(np.argmin(firsts))


def _hold_release(t: FloatArray, y: FloatArray, hold: float, onset: int, period: float) -> Knot | None:
    """A pull-hold release: the cart held still away from its rest (the spring pulls it back:
    the hold level is further than `HOLD_AWAY` of the swing from the middle of the swings),
    let go where its acceleration jumps, next to the motion onset; None for a flick (it
    starts from the rest it returns to) or when no jump stands out of the noise."""
    after = y[onset:]
    swing = float(np.max(np.abs(after - hold)))
    # the middle of the swings is about where the spring's rest is: a flick starts there
    if abs(0.5 * float(np.max(after) + np.min(after)) - hold) < HOLD_AWAY * swing:
        return None
    return hold_release(t, y, hold, onset, period)


def _last_rest_before(t_start: float, fit: ModalFit, period: float, hold: FloatArray, tolerance: float) -> float:
    """The release: the latest τ ∈ [-T/2, 0] where the main output's fitted velocity is zero,
    as t_start + τ, when the fitted position there is the held level (a clean release from
    rest, within `tolerance` m); otherwise `t_start` (the hand let go while the cart moved)."""
    tau = np.linspace(-0.5 * period, 0.0, 400)
    main = int(np.argmax(np.abs(fit.amplitudes).sum(axis=1)))
    pos = np.full_like(tau, fit.rest[main])
    vel = np.zeros_like(tau)
    for j, (w, s) in enumerate(zip(fit.freqs, fit.decays)):
        a, b = fit.amplitudes[main, j].real, -fit.amplitudes[main, j].imag
        env = np.exp(-s * tau)
        pos += env * (a * np.cos(w * tau) + b * np.sin(w * tau))
        vel += env * ((-s * a + w * b) * np.cos(w * tau) + (-s * b - w * a) * np.sin(w * tau))
    change = np.flatnonzero(np.sign(vel[1:]) != np.sign(vel[:-1]))
    if change.size == 0:
        return t_start
    i = int(change[-1])
    frac = vel[i] / (vel[i] - vel[i + 1])
    if abs(pos[i] + frac * (pos[i + 1] - pos[i]) - hold[main]) > tolerance:
        return t_start
    return float(t_start + tau[i] + frac * (tau[i + 1] - tau[i]))
