"""What a diagnosis fits: the record's columns that move, checked, cut to the release's window
(`release_stretch`), its free carts and a held cart's column. No fitting and no I/O here."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.data import stamps_line
from ident.diagnose.fitting import MOVING_SHARE, last_moving
from ident.diagnose.still import Outputs, moving_outputs
from ident.diagnose.window import MAX_WORK_SAMPLES, MIN_RELEASE_SAMPLES, Window, find_window, hold_level
from ident.errors import IdentDimensionError, IdentValueError
from ident.physics.measures import encoder_quantum, noise_std, spectral_peaks, spectrum
from ident.releases.record import HELD_FRACTION, Release

FloatArray = NDArray[np.float64]


def release_stretch(t: FloatArray, y: FloatArray, u: FloatArray | None, carts: int | None,
                    start_s: float | None, stop_s: float | None, finest: int | None = None) -> Stretch:
    """`t` (N,), `y` (N, k) cut to [`start_s`, `stop_s`] (`diagnose`'s arguments), or by default,
    without a force input `u`, to the first complete release `ident.releases` finds (up to the
    next release), dated by the window's scan and, for one cart, from the later of the two
    instants. The window's own scan had dated generated flicks of a cart carrying a sprung mass
    100-135 ms before the hand let go (the fit starting in the push, 70-94 % for a 98.9-99.8 %
    floor), where `ident releases` dates them 3-23 ms off; that dates 10 of 46 other generated
    flicks 4-67 samples early where the scan is within 3. So for one cart the later of the two
    is taken: a fit that starts a little after the let-go loses a few samples, one that starts
    in the push fits it. Not for a chain: `ident.releases` models each measured cart as one
    free cart, and two carts read through one encoder (two modes in one column) it dated up to
    47 samples late on generated runs that the scan dates within one. From a still hold
    (`_from_hold`; one cart, or a chain read cart by cart) the motion's onset is the release:
    `ident releases` dates it within a sample where the scan dated generated Coulomb holds up to
    72 samples late, and its instant is taken. `finest`: a free window's decimation at most (its
    modes resolved, `resolving_decimation`), cut where the work samples run out."""
    found = None
    if start_s is None and stop_s is None and u is None:
        found, stop_s = _first_release(t, y)
    cut = _cut(t, y, u, carts, start_s, stop_s, finest)
    if found is None or cut.y.shape[1] < cut.carts:
        return cut      # a chain read through one encoder: the scan's instant
    agree = RELEASE_AGREE * float(t[1] - t[0])
    scan, instant = cut.win.release_time_s, found.release_time_s
    pulled = cut.y_all[:, min(found.pulled_cart, cut.y_all.shape[1]) - 1]
    early = cut.carts == 1 and scan < instant - agree
    if early or (scan > instant + agree and _from_hold(cut.t, pulled, found)):
        # the fit starts where `ident releases` dates the release: for one cart after the scan's
        # instant, and at a still hold's onset, which the scan dates late
        cut = _cut(t, y, u, carts, instant, stop_s, finest)
    return cut


#: A release is from a still hold when the cart moved less than this share of its first free
#: swing in the quarter period before it (the two generated holds above: 0.1 %; a flick's push
#: moves the cart by much of its swing).
HOLD_STILL = 0.05


def _from_hold(t: FloatArray, y: FloatArray, release: Release) -> bool:
    """Whether the cart (`y` (N,)) was held still before `release`: its span over the quarter
    period before it under `HOLD_STILL` of its span over the half-period after."""
    instant, period = release.release_time_s, release.period_s
    if not np.isfinite(period) or period <= 0:
        return False
    before = y[(t >= instant - 0.25 * period) & (t < instant)]
    after = y[(t >= instant) & (t <= instant + 0.5 * period)]
    if before.size < 3 or after.size < 3:
        return False
    return float(np.ptp(before)) < HOLD_STILL * float(np.ptp(after))


def check_input(u: FloatArray | None, n: int) -> FloatArray | None:
    """A force input `u` (N,) or (N, m) as (N, m), checked against `n` samples; None stays None."""
    if u is None:
        return None
    u_arr = np.asarray(u, dtype=np.float64)
    u_arr = u_arr.reshape(u_arr.shape[0], -1) if u_arr.ndim else u_arr.reshape(1, 1)
    if u_arr.shape[0] != n:
        raise IdentDimensionError("u", f"{n} input samples (one per time)", u_arr.shape[0])
    if not np.all(np.isfinite(u_arr)):
        raise IdentValueError("u", "finite input values", "NaN or inf")
    return u_arr


#: The window's scan and `ident.releases` agree on a release this many samples apart (the scan's
#: window then starts its own margin after it, `window._from`).
RELEASE_AGREE = 2.0


@dataclass(frozen=True)
class Stretch:
    """The stretch diagnosed: times, every column, the input, the cart count, the fitted columns,
    a held cart's column and the release window."""

    t: FloatArray
    y_all: FloatArray
    u: FloatArray | None
    carts: int
    y: FloatArray
    other: int | None
    win: Window


def _cut(t: FloatArray, y: FloatArray, u: FloatArray | None, carts: int | None, start_s: float | None,
         stop_s: float | None, finest: int | None = None) -> Stretch:
    """The record cut to [`start_s`, `stop_s`] (a start given: the hand let go there, the
    release reported at that instant), its carts (`_free_carts` unless given) and release
    window, decimated at most `finest` (a free window)."""
    keep = _kept(t, start_s, stop_s)
    t_k, y_k = t[keep], y[keep]
    u_k = None if u is None else u[keep]
    n = carts or _free_carts(y_k)
    fitted, other = _select_outputs(y_k, n)
    win = _window(t_k, fitted, n, u_k, start_s is not None)
    if start_s is not None and u is None:   # the instant itself, not the first sample after it
        win = dataclasses.replace(win, release_time_s=max(start_s, float(t[0])))
    if u is None:
        stop, decimation = still_tail_cut(fitted[win.start:])
        if finest is not None and finest < decimation:   # (then 500·finest samples < the window)
            stop, decimation = MAX_WORK_SAMPLES * finest, finest
    else:
        stop, decimation = modes_resolved_cut(fitted, float(t_k[1] - t_k[0]), n)
    if stop is not None:
        end = win.start + stop
        t_k, y_k, fitted = t_k[:end], y_k[:end], fitted[:end]
        u_k = None if u_k is None else u_k[:end]
        win = dataclasses.replace(win, decimation=decimation, tail_cut=True)
    return Stretch(t_k, y_k, u_k, n, fitted, other, win)


#: A force-driven record's work grid keeps at least this many samples per period of its
#: fastest mode (`modes_resolved_cut`).
MIN_SAMPLES_PER_PERIOD = 6
#: ... of a mode whose positions' power at its peak is this many times their noise floor (the
#: median power over the upper half of the band).
MODE_OVER_NOISE = 100.0


def resolving_decimation(wn_rad_s: float, dt: float) -> int:
    """The coarsest decimation of samples `dt` (s) apart that keeps `MIN_SAMPLES_PER_PERIOD`
    a period of a mode of `wn_rad_s`. A free window decimated to `MAX_WORK_SAMPLES` work
    samples may not: a stiff cart (5.8 Hz) that dry friction stopped early, dragged in
    stick-slip by a wandering held cart to the end of an 18 s record at 222 Hz, had one
    sample in 8 (4 a period): friction 50 % off and the coupling not found; one in 5, 1.8 %
    and 4.9 % (`testkit.effects` coulomb+held_cart, seed 451227722, wide carts)."""
    return max(1, int(2.0 * np.pi / wn_rad_s / (dt * MIN_SAMPLES_PER_PERIOD)))


def modes_resolved_cut(y: FloatArray, dt: float, carts: int) -> tuple[int | None, int]:
    """(samples kept, decimation) of a record driven by a force input (`y` (N, k), the whole
    record from its start): None when it is kept whole.

    Decimated to `MAX_WORK_SAMPLES` work samples, a long record is sampled too coarsely for
    its modes: the PoliMi three-cart rig's 49.6 s of five current pulses at 200 Hz became a
    10 Hz work grid under a 5.9 Hz mode (1.7 samples a period). Its decimation is then what
    keeps `MIN_SAMPLES_PER_PERIOD` samples a period of the fastest of the `carts` strongest
    peaks of the positions' second differences (the modes' ringing; the input's own slow
    content dominates the positions' spectrum), and the record is cut where the work samples
    run out (the PoliMi record: its first pulse and the ring after it, 12.5 s)."""
    n = y.shape[0]
    decimation = max(1, int(np.ceil(n / MAX_WORK_SAMPLES)))
    if decimation == 1 or n < 8:
        return None, decimation
    # a peak is a mode's only where the positions ring well above their noise there: the
    # reading noise's second differences rise as ω⁴ and peak at the top of the band (a
    # generated pulse read with 20 µm of noise at 500 Hz had one at 41 Hz)
    w, power = spectrum(y, dt)
    floor = float(np.median(power[power.size // 2:]))
    peaks = spectral_peaks(np.diff(y, 2, axis=0), dt, carts, fill=False,
                           max_rad_s=np.pi / (dt * MIN_SAMPLES_PER_PERIOD))
    peaks = peaks[np.interp(peaks, w, power) > MODE_OVER_NOISE * floor]
    if not peaks.size:
        return None, decimation
    need = resolving_decimation(float(np.max(peaks)), dt)
    return (MAX_WORK_SAMPLES * need, need) if need < decimation else (None, decimation)


def still_tail_cut(y: FloatArray) -> tuple[int | None, int]:
    """(samples kept, decimation) of a window `y` (N, k) of the fitted carts whose carts stop
    early: None when it is kept whole.

    A window is decimated to at most `MAX_WORK_SAMPLES` work samples. When every column has
    stopped before half of it (`_motion_end`), it is decimated only as much as the motion and
    a still tail as long need, and cut in the tail where the work samples run out: a cart that dry
    friction stops in 2 s of a 15 s record at 55 Hz had its motion fitted on every second
    sample, and the friction (+5.3 points on the whole window) did not hold out (red team
    `two_cart_coulomb_y1` seed 11: held-out ratio 4.8 against a bound of 13.8; 93 on 9 s
    undecimated). Where each cart rests is still seen. A held cart's column is the fitted
    cart's input, not one of these: its hand wanders to the record's end, and judged with it a
    stiff cart that friction stopped in 0.6 s of a 16.6 s record at 650 Hz was fitted on one
    sample in 22, five a period (friction 43 % off, a 4.9 Hz 'mode' the headline;
    `testkit.effects` coulomb+held_cart seed 108, 18 s, wide carts)."""
    n = y.shape[0]
    if n <= MAX_WORK_SAMPLES:
        return None, 1
    moving = _motion_end(y)
    decimation = max(1, int(np.ceil(2 * moving / MAX_WORK_SAMPLES)))
    kept = min(n, MAX_WORK_SAMPLES * decimation)
    return (kept, decimation) if kept < n else (None, int(np.ceil(n / MAX_WORK_SAMPLES)))


#: A column moves while it is farther from its final level than `fitting.MOVING_SHARE` of its
#: span, or than this many noise σ plus one encoder count.
STILL_SIGMAS = 4.0


def _motion_end(y: FloatArray) -> int:
    """Samples of `y` (N, k) up to the last one where some column moves (`STILL_SIGMAS`): a
    resting cart read through a 1.6 mm lattice under 1 mm of noise flips between levels 2 % of
    its span apart to the window's end."""
    bound = np.maximum(MOVING_SHARE * np.ptp(y, axis=0), STILL_SIGMAS * noise_std(y) + encoder_quantum(y))
    return last_moving(y, bound)


def _first_release(t: FloatArray, y: FloatArray) -> tuple[Release | None, float | None]:
    """The first complete release `ident.releases` finds in the record (else its first) and
    the window's end (s), None unless the next release ends it: a touch of the held cart is its
    measured motion, an input the diagnosis takes (ended there, generated held-cart runs lost
    the breakaways a wandering hand causes after the cart stuck: Coulomb + held cart seed
    2086437318 named only a mode); (None, None) when it finds none, or one too short to
    diagnose."""
    from ident.releases import FIRST_COMPLETE, choose, find_releases

    releases = find_releases(t, y)
    if not releases:
        return None, None
    release = choose(releases, FIRST_COMPLETE)
    inside = np.count_nonzero((t >= release.release_time_s) & (t <= release.end_time_s))
    if inside < MIN_RELEASE_SAMPLES:
        return None, None
    return release, (release.end_time_s if release.ended_by == "release" else None)


def _kept(t: FloatArray, start_s: float | None, stop_s: float | None) -> NDArray[np.bool_]:
    keep = np.ones(t.size, dtype=bool)
    if start_s is not None:
        keep &= t >= start_s
    if stop_s is not None:
        keep &= t <= stop_s
    if keep.sum() < MIN_RELEASE_SAMPLES:
        raise IdentValueError("window", f"at least {MIN_RELEASE_SAMPLES} samples between start and stop",
                              f"{int(keep.sum())} samples in [{start_s}, {stop_s}] s")
    return keep


def _window(t: FloatArray, y: FloatArray, carts: int, u: FloatArray | None, released_at_start: bool) -> Window:
    """The release window; with a force input the whole record (the input drives the motion)."""
    if u is None:
        return find_window(t, y, carts, released_at_start)
    hold, noise, _ = hold_level(y)
    # the input's onset: the first sample where it acts (2023 DOF1_en1_input1_test4 starts on
    # its step: its first change, the reversal at 3 s, had been reported)
    moved = np.flatnonzero(np.any(u != 0.0, axis=1))
    release = float(t[moved[0]]) if moved.size else float(t[0])
    decimation = max(1, int(np.ceil(t.size / MAX_WORK_SAMPLES)))
    return Window(0, decimation, hold, noise, release, float("nan"))


def moving(y: FloatArray, carts: int | None) -> Outputs:
    """`y`'s columns that move (`ident.diagnose.still`); a `y` of a wrong shape is passed on
    whole, for `check` to refuse."""
    y_arr = np.asarray(y, dtype=np.float64)
    y_arr = y_arr[:, None] if y_arr.ndim == 1 else y_arr
    if y_arr.ndim != 2:
        return Outputs(y_arr, (), {})
    return moving_outputs(y_arr, carts)


def check(t: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """`t` (N,) and `y` as (N, k): finite, at least 50 samples, on a uniform increasing grid
    (steps within 1 % of each other), `t` returned on its least-squares line
    (`ident.data.stamps_line`): the diagnosis steps its simulation by t[1] - t[0], and a first
    step 0.9 % off the others (a 25 Hz record whose clock rounds) had put wn 0.9 % high."""
    t_arr = np.asarray(t, dtype=np.float64)
    y_arr = np.asarray(y, dtype=np.float64)
    if y_arr.ndim == 1:
        y_arr = y_arr[:, None]
    if t_arr.ndim != 1 or y_arr.ndim != 2 or y_arr.shape[0] != t_arr.shape[0]:
        raise IdentDimensionError("t, y", "t (N,) and y (N,) or (N, n_out)",
                                  f"t {t_arr.shape}, y {y_arr.shape}")
    if t_arr.size < 50:
        raise IdentValueError("run length", "at least 50 samples", t_arr.size)
    if not (np.all(np.isfinite(t_arr)) and np.all(np.isfinite(y_arr))):
        raise IdentValueError("t, y", "finite values", "NaN or inf")
    dt = np.diff(t_arr)
    if np.any(dt <= 0) or np.ptp(dt) > 0.01 * float(np.median(dt)):
        raise IdentValueError("time steps", "a uniform increasing grid (use ident.make_uniform)",
                              f"steps from {dt.min():.6g} to {dt.max():.6g} s")
    return stamps_line(t_arr), y_arr


def _free_carts(y: FloatArray) -> int:
    """Carts to fit when the caller does not say: the columns of `y` (N, n_out) that swing at
    least `HELD_FRACTION` of the largest swing, at most two (as `_select_outputs` tells a held
    cart; a held cart that wanders by a millimetre had been fitted as a chain's free cart: the
    real 2025 hand releases through the API at 47-59 %)."""
    swing = np.ptp(y, axis=0)
    return min(int(np.count_nonzero(swing >= HELD_FRACTION * float(np.max(swing)))), 2)


def _select_outputs(y: FloatArray, carts: int) -> tuple[FloatArray, int | None]:
    """The outputs to fit, and the column of a held cart (one-cart fits of two columns).
    Two carts with one column: the chain read through cart 1's encoder."""
    if carts not in (1, 2):
        raise IdentValueError("carts", "1 or 2", carts)
    if carts == 2 and y.shape[1] == 1:
        return y, None                 # two carts through cart 1's encoder
    if y.shape[1] < carts:
        raise IdentDimensionError("positions", f"{carts} position columns", y.shape[1])
    if carts == 1 and y.shape[1] > 1:
        swing = np.ptp(y, axis=0)
        main = int(np.argmax(swing))
        others = [j for j in range(y.shape[1]) if j != main and 0 < swing[j] < HELD_FRACTION * swing[main]]
        other = max(others, key=lambda j: swing[j]) if others else None
        return y[:, [main]], other
    return y[:, :carts], None


__all__ = ["RELEASE_AGREE", "Stretch", "check", "check_input", "moving", "release_stretch"]
