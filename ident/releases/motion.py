"""Motion of a raw record: a uniform grid, the oscillation period, smoothed derivatives.

All arrays time-major: `t` (N,) s, `y` (N, n) m. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.data import stamps_line, uniform_grid
from ident.physics.measures import noise_std, spectral_peaks

FloatArray = NDArray[np.float64]

#: Oscillation frequencies a lab cart on springs can have (Hz): anything outside is drift or noise.
MIN_FREQUENCY_HZ = 0.2
#: Smoothing window of the derivatives, as a fraction of the period (a cubic fits a sinusoid
#: to ~1e-3 over a tenth of a period, and the window averages the encoder's quantization).
SMOOTHING_FRACTION = 0.1
#: ... longer, up to this fraction, where the encoder's noise would hide a releasing hand: the
#: smoothed acceleration's noise must stay within this fraction of the swing's ω²A, so that a
#: hand of `judge.HAND_FORCE_FRACTION` (0.3) of the spring's force clears `hand.HAND_SIGMAS` (6)
#: noise stds (a 2 mm lattice with noise before it, read at 260 Hz: 0.61 of it over a tenth of
#: a period, and no release was found in a clean flick).
MAX_SMOOTHING_FRACTION = 0.25
ACCEL_NOISE_FRACTION = 0.05
#: A velocity-spectrum peak slower than the turning points by more than this ratio is a slow
#: push, not the oscillation (`dominant_period`).
SLOW_PEAK_RATIO = 0.65
#: ... and one faster than them by more than this ratio is noise.
FAST_PEAK_RATIO = 0.5
#: A cart moves where its speed exceeds this fraction of its near-largest (`typical_speed`).
MOVING_FRACTION = 0.05


@dataclass(frozen=True)
class Motion:
    """A record on a uniform grid with its smoothed position, velocity and acceleration.

    `t` (N,) s; `y`, `x`, `v`, `a` (N, n) in m, m/s, m/s²; `dt` s; `period_s` the dominant
    oscillation period; `noise_m` (n,) the per-column measurement noise std; `window` the
    smoothing window (samples); `x_noise_m` (n,) the noise left in `x`; `uneven_stamps` whether
    the record's stamps were uneven (a coarse clock's, interpolated onto the grid: `uniform`),
    whose errors misplace a moving cart by its speed times up to a stamp's step.
    """

    t: FloatArray
    y: FloatArray
    x: FloatArray
    v: FloatArray
    a: FloatArray
    dt: float
    period_s: float
    noise_m: FloatArray
    window: int
    x_noise_m: FloatArray
    uneven_stamps: bool = False

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    def samples(self, seconds: float) -> int:
        """A duration as a whole number of samples (at least 1)."""
        return max(1, round(seconds / self.dt))


def uniform(t: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray, bool]:
    """`(t, y)` on a uniform grid, same time base, and whether the stamps were uneven. When
    the steps differ by no more than 1 %, the readings as they are on the stamps' least-squares
    line t0 + k·Ts (every index and time of the finder is t0 + k·Ts: taken from the first
    step, a record read at 25 Hz whose first step was 0.9 % short of the others dated a release
    80 ms early 9 s on); else linearly interpolated onto `ident.data.uniform_grid` (which evens
    out a coarse clock's stamps first: the ECP Teensy's whole ms on ~1.13 ms samples)."""
    dt = np.diff(t)
    step = float(np.median(dt))
    if float(np.max(np.abs(dt - step))) <= 0.01 * step:
        return stamps_line(t), y, False
    times, grid = uniform_grid(t, y)
    return grid, np.column_stack([np.interp(grid, times, col) for col in y.T]), True


def dominant_period(y: FloatArray, dt: float) -> float:
    """The period (s) of the strongest oscillation: the peak of the summed velocity spectra.

    Velocity (first differences) rather than position, so slow drift and steps of a held
    cart do not win; the peak is searched between `MIN_FREQUENCY_HZ` and a fifth of the
    sample rate by the one spectral-peak finder (`ident.physics.spectral_peaks`). A short
    record whose hand moved the cart slowly (a pull over most of a second, then a second of
    ringing) can put that peak at the pull's slow bump: when the widest column's turning
    points (`turning_period`) come at less than `SLOW_PEAK_RATIO` of that period, the
    peak is searched again above the frequency they imply (less a third). A peak faster than
    the turning points by more than `FAST_PEAK_RATIO` is the noise's (the difference of white
    noise or of a coarse lattice's steps grows with frequency: a long record that rings for
    a few cycles at 600 Hz put it at the top of the band): it is searched again below
    that.
    """
    vel = np.diff(y, axis=0)
    if vel.shape[0] < 3:
        return 1.0 / max(MIN_FREQUENCY_HZ, 1.0 / (dt * max(len(y), 2)))
    top = 2.0 * np.pi * 0.2 / dt
    peaks = spectral_peaks(vel, dt, 1, min_rad_s=2.0 * np.pi * MIN_FREQUENCY_HZ, max_rad_s=top, fill=False)
    if peaks.size == 0:
        return 1.0 / max(MIN_FREQUENCY_HZ, 1.0 / (dt * max(len(y), 2)))
    period = float(2.0 * np.pi / peaks[0])
    turns = turning_period(y, dt)
    if turns is not None and turns < SLOW_PEAK_RATIO * period:
        again = spectral_peaks(vel, dt, 1, min_rad_s=2.0 * np.pi / (1.5 * turns), max_rad_s=top, fill=False)
        if again.size:
            return float(2.0 * np.pi / again[0])
    if turns is not None and period < FAST_PEAK_RATIO * turns:
        again = spectral_peaks(vel, dt, 1, min_rad_s=2.0 * np.pi * MIN_FREQUENCY_HZ,
                               max_rad_s=min(top, 2.0 * np.pi / (FAST_PEAK_RATIO * turns)), fill=False)
        if again.size:
            return float(2.0 * np.pi / again[0])
    return period


def typical_speed(v: FloatArray) -> float:
    """The speed (m/s) of a cart's swing from its velocity `v` (N,): the 95th percentile of
    |v| over the samples where it moves (|v| beyond `MOVING_FRACTION` of its 99.9th
    percentile). Not over the whole record: a cart that dry friction stops within a few
    cycles of a long record is still for most of it, and the percentile of every sample
    is then the velocity noise of a stuck cart (a free model fitted on "moving" samples of
    noise explains nothing: red-team Coulomb cases stuck from 2-3 s of 10-20 s)."""
    speed = np.abs(v)
    moving = speed > MOVING_FRACTION * float(np.percentile(speed, 99.9))
    return float(np.percentile(speed[moving], 95)) if np.any(moving) else 0.0


def moving_samples(v: FloatArray, speed: float | None = None) -> NDArray[np.bool_]:
    """(N,) where a cart of velocity `v` (N,) moves: |v| beyond `MOVING_FRACTION` of its
    typical speed (`speed`, default `typical_speed(v)`)."""
    return np.asarray(np.abs(v) > MOVING_FRACTION * (typical_speed(v) if speed is None else speed))


def turning_period(y: FloatArray, dt: float) -> float | None:
    """Twice the median time (s) between the turns of the widest column (`turning_indices`,
    reversals by more than 5 % of its robust range and 10 noise stds): a ringing cart turns
    every half period. None with fewer than two turns."""
    span = np.percentile(y, 99.5, axis=0) - np.percentile(y, 0.5, axis=0)
    j = int(np.argmax(span))
    x = y[:, j]
    hysteresis = max(0.05 * float(span[j]), 10.0 * float(noise_std(y)[j]))
    if not hysteresis > 0.0:
        return None
    turns = turning_indices(x, hysteresis)
    if turns.size < 2:
        return None
    return 2.0 * float(np.median(np.diff(turns))) * dt


def turning_indices(x: FloatArray, hysteresis: float) -> NDArray[np.intp]:
    """The samples where `x` (N,) is seen to have turned: each first sample that lies more
    than `hysteresis` back from the extreme of its swing. (Not the extreme itself: a cart
    held still at its extreme turns where the hand lets it go, not at the hold's flattest
    sample.)"""
    found: list[int] = []
    if x.size == 0:
        return np.asarray(found, dtype=np.intp)
    direction, low, high = 0, float(x[0]), float(x[0])
    for k, value in enumerate(x):
        v = float(value)
        if direction >= 0:
            if v > high:
                high = v
            elif high - v > hysteresis:
                if direction > 0:
                    found.append(k)
                direction, low = -1, v
        if direction <= 0:
            if v < low:
                low = v
            elif v - low > hysteresis:
                if direction < 0:
                    found.append(k)
                direction, high = 1, v
    return np.asarray(found, dtype=np.intp)


def motion(t: FloatArray, y: FloatArray) -> Motion:
    """Grid, period, noise and Savitzky–Golay (cubic) derivatives of a record."""
    from scipy.signal import savgol_filter  # deferred: keeps `import ident` fast
    t_arr = np.asarray(t, dtype=np.float64)
    t_u, y_u, uneven = uniform(t_arr, np.asarray(y, dtype=np.float64).reshape(len(t), -1))
    dt = float(t_u[1] - t_u[0])
    period = dominant_period(y_u, dt)
    noise = measurement_noise(np.asarray(y, dtype=np.float64).reshape(len(t), -1))
    window = smoothing_window(y_u, dt, period)
    x = savgol_filter(y_u, window, 3, axis=0, mode="interp")
    v = savgol_filter(y_u, window, 3, deriv=1, delta=dt, axis=0, mode="interp")
    a = savgol_filter(y_u, window, 3, deriv=2, delta=dt, axis=0, mode="interp")
    return Motion(t_u, y_u, x, v, a, dt, period, noise, window, smoothed_noise(noise, window), uneven)


def smoothing_window(y: FloatArray, dt: float, period: float) -> int:
    """The derivatives' Savitzky-Golay window (odd, samples): `SMOOTHING_FRACTION` of a period,
    longer (to `MAX_SMOOTHING_FRACTION`) until the acceleration's noise, σ ‖c‖ / dt² (c the
    cubic's second-derivative coefficients), is within `ACCEL_NOISE_FRACTION` of ω²A of the
    widest column (A half its robust range). σ is what that column's readings scatter about
    the cubic over the shorter window (rms, less the filter's own share): at a coarse
    rate a second difference holds the swing's curvature too (50 Hz, an 18 µm encoder: 0.43 mm),
    which had lengthened the window of a clean record and let a nudge through."""
    from scipy.signal import savgol_coeffs, savgol_filter  # deferred: keeps `import ident` fast
    longest = y.shape[0] - (1 - y.shape[0] % 2)
    span = np.percentile(y, 99.5, axis=0) - np.percentile(y, 0.5, axis=0)
    j = int(np.argmax(span))
    swing = (2.0 * np.pi / period) ** 2 * 0.5 * float(span[j])

    def odd(fraction: float) -> int:
        return min(max(5, 2 * round(fraction * period / dt / 2) + 1), longest)

    window, last = odd(SMOOTHING_FRACTION), odd(MAX_SMOOTHING_FRACTION)
    if window >= last:
        return window
    scatter = y[:, j] - savgol_filter(y[:, j], window, 3)
    # a projection's residual keeps 1 - c_mid of the noise's variance
    keep = 1.0 - float(savgol_coeffs(window, 3)[window // 2])
    sigma = float(np.sqrt(np.mean(scatter ** 2) / keep))
    while window < last and sigma * accel_noise_gain(window, dt) > ACCEL_NOISE_FRACTION * swing:
        window += 2
    return window


def accel_noise_gain(window: int, dt: float) -> float:
    """The smoothed acceleration's noise std (m/s²) per metre of the readings' noise std: ‖c‖ / dt²,
    c the cubic's second-derivative coefficients over `window` samples `dt` apart."""
    from scipy.signal import savgol_coeffs  # deferred: keeps `import ident` fast
    return float(np.linalg.norm(savgol_coeffs(window, 3, deriv=2))) / dt ** 2


def smoothed_noise(noise: FloatArray, window: int) -> FloatArray:
    """The noise std (m) left in a position smoothed by the cubic of `window` samples."""
    from scipy.signal import savgol_coeffs  # deferred: keeps `import ident` fast
    return np.asarray(noise * float(np.linalg.norm(savgol_coeffs(window, 3))))


def accel_noise(m: Motion, column: int, ringing: bool = False) -> float:
    """The noise std (m/s²) in column `column`'s smoothed acceleration (`accel_noise_gain`);
    with `ringing`, of the reading noise estimated from fourth differences (`noise_std`: a
    cart that rings through the record at a low rate leaves no sample where its second
    difference is noise alone)."""
    noise = float(measurement_noise(m.y[:, [column]], 4)[0]) if ringing else float(m.noise_m[column])
    return noise * accel_noise_gain(m.window, m.dt)


def measurement_noise(y: FloatArray, order: int = 2) -> FloatArray:
    """Per-column noise std (m), (n,): white noise from differences of `order` (`noise_std`),
    never below the encoder's quantization noise q/√12 (q the smallest step between samples),
    which a slow cart read at a high rate hides from the differences."""
    steps = np.abs(np.diff(y, axis=0))
    quanta = np.array([float(np.min(col[col > 0])) if np.any(col > 0) else 0.0 for col in steps.T])
    return np.asarray(np.maximum(noise_std(y, order), quanta / np.sqrt(12.0)))
