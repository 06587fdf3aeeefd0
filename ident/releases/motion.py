"""Motion of a raw record: a uniform grid, the oscillation period, smoothed derivatives.

All arrays time-major: `t` (N,) s, `y` (N, n) m. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.physics.measures import noise_std, spectral_peaks

FloatArray = NDArray[np.float64]

#: Oscillation frequencies a lab cart on springs can have (Hz): anything outside is drift or noise.
MIN_FREQUENCY_HZ = 0.2
#: Smoothing window of the derivatives, as a fraction of the period (a cubic fits a sinusoid
#: to ~1e-3 over a tenth of a period, and the window averages the encoder's quantization).
SMOOTHING_FRACTION = 0.1


@dataclass(frozen=True)
class Motion:
    """A record on a uniform grid with its smoothed position, velocity and acceleration.

    `t` (N,) s; `y`, `x`, `v`, `a` (N, n) in m, m/s, m/s²; `dt` s; `period_s` the dominant
    oscillation period; `noise_m` (n,) the per-column measurement noise std; `window` the
    smoothing window (samples).
    """

    t: FloatArray
    y: FloatArray
    x: FloatArray
    v: FloatArray
    a: FloatArray
    dt: float
    period_s: float
    noise_m: FloatArray
    window: int = 5

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    def samples(self, seconds: float) -> int:
        """A duration as a whole number of samples (at least 1)."""
        return max(1, round(seconds / self.dt))


def uniform(t: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """`(t, y)` on a uniform grid from `t[0]` with the median step (linear interpolation when
    the steps differ by more than 1 %: the ECP Teensy's 1 ms / 2 ms steps), same time base."""
    dt = np.diff(t)
    step = float(np.median(dt))
    if float(np.max(np.abs(dt - step))) <= 0.01 * step:
        return t, y
    n = int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1
    grid = np.minimum(t[0] + step * np.arange(n), t[-1])
    return grid, np.column_stack([np.interp(grid, t, col) for col in y.T])


def dominant_period(y: FloatArray, dt: float) -> float:
    """The period (s) of the strongest oscillation: the peak of the summed velocity spectra.

    Velocity (first differences) rather than position, so slow drift and steps of a held
    cart do not win; the peak is searched between `MIN_FREQUENCY_HZ` and a fifth of the
    sample rate by the one spectral-peak finder (`ident.physics.spectral_peaks`).
    """
    vel = np.diff(y, axis=0)
    if vel.shape[0] < 3:
        return 1.0 / max(MIN_FREQUENCY_HZ, 1.0 / (dt * max(len(y), 2)))
    peaks = spectral_peaks(vel, dt, 1, min_rad_s=2.0 * np.pi * MIN_FREQUENCY_HZ,
                           max_rad_s=2.0 * np.pi * 0.2 / dt, fill=False)
    if peaks.size == 0:
        return 1.0 / max(MIN_FREQUENCY_HZ, 1.0 / (dt * max(len(y), 2)))
    return float(2.0 * np.pi / peaks[0])


def motion(t: FloatArray, y: FloatArray) -> Motion:
    """Grid, period, noise and Savitzky–Golay (cubic) derivatives of a record."""
    from scipy.signal import savgol_filter  # deferred: keeps `import ident` fast
    t_u, y_u = uniform(np.asarray(t, dtype=np.float64), np.asarray(y, dtype=np.float64).reshape(len(t), -1))
    dt = float(t_u[1] - t_u[0])
    period = dominant_period(y_u, dt)
    window = max(5, 2 * round(SMOOTHING_FRACTION * period / dt / 2) + 1)
    window = min(window, y_u.shape[0] - (1 - y_u.shape[0] % 2))
    x = savgol_filter(y_u, window, 3, axis=0, mode="interp")
    v = savgol_filter(y_u, window, 3, deriv=1, delta=dt, axis=0, mode="interp")
    a = savgol_filter(y_u, window, 3, deriv=2, delta=dt, axis=0, mode="interp")
    return Motion(t_u, y_u, x, v, a, dt, period,
                  measurement_noise(np.asarray(y, dtype=np.float64).reshape(len(t), -1)), window)


def measurement_noise(y: FloatArray) -> FloatArray:
    """Per-column noise std (m), (n,): white noise from second differences, never below the
    encoder's quantization noise q/√12 (q the smallest step between samples), which a slow
    cart read at a high rate hides from the differences."""
    steps = np.abs(np.diff(y, axis=0))
    quanta = np.array([float(np.min(col[col > 0])) if np.any(col > 0) else 0.0 for col in steps.T])
    return np.asarray(np.maximum(noise_std(y), quanta / np.sqrt(12.0)))
