"""Where the free response starts: hold level, motion onset, the hand's influence, the release.

A release is not always clean (DESIGN.md): the hand may let go while the cart moves. The
free response is therefore fitted from a window start `t_w` with the state at `t_w` as
parameters. `t_w` is the earliest candidate start, from the motion onset on, whose
short-window modal fit is as good as the best one (the hand no longer acts after it):

    onset: first sample with |y - hold| > max(8 σ_hold, 3 % of the excursion);
    candidates t_w = onset + j·T/16, j = 0..8 (T the oscillation period);
    rms_j of a one-mode-per-cart fit on [t_w, t_w + 2.5 T];
    t_w = first j with rms_j ≤ max(2 min rms, min rms + 3 σ_hold).

The reported release time is the last zero of the fitted velocity before `t_w` (within half
a period): the instant a clean release starts from rest, the extreme of a flick. Long runs
are decimated for fitting (`MAX_WORK_SAMPLES`). No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.modal import fit_modes, spectral_peaks
from ident.errors import IdentValueError

FloatArray = NDArray[np.float64]

MAX_WORK_SAMPLES = 500
SCAN_STEPS = 9


@dataclass(frozen=True)
class Window:
    """The fitted stretch of a run.

    `start` index of t_w in the full run; `decimation` D (every D-th sample is used);
    `hold` (n_out,) held level before the motion; `hold_noise_m` its scatter;
    `release_time_s` the estimated release; `period_s` the dominant period.
    """

    start: int
    decimation: int
    hold: FloatArray
    hold_noise_m: float
    release_time_s: float
    period_s: float


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
    mad = float(np.median(np.abs(quiet[:, main] - hold[main]))) * 1.4826
    noise = mad if quiet.shape[0] >= 8 else 0.0
    dev = np.abs(y[:, main] - hold[main])
    threshold = max(8.0 * noise, 0.03 * float(np.max(dev)))
    onset = int(np.flatnonzero(dev > threshold)[0])
    return hold, noise, onset


def find_window(t: FloatArray, y: FloatArray, carts: int) -> Window:
    """Window start, decimation, hold and release time of a run `y` (N, n_out) on `t` (N,)."""
    dt = float(t[1] - t[0])
    hold, noise, onset = hold_level(y)
    if t.shape[0] - onset < 40:
        raise IdentValueError("run", "at least 40 samples after the motion starts",
                              f"{t.shape[0] - onset}")
    after = y[onset:]
    peaks = spectral_peaks(after - after.mean(axis=0), dt, carts)
    period = 2 * np.pi / float(peaks[0])
    span = int(round(2.5 * period / dt))
    step = max(1, int(round(period / 16 / dt)))
    dec = max(1, int(np.ceil(span / 150)))
    rms: list[float] = []
    fits = []
    for j in range(SCAN_STEPS):
        a = onset + j * step
        b = min(a + span, t.shape[0])
        if b - a < 20:
            break
        tau = t[a:b:dec] - t[a]
        fit = fit_modes(tau, y[a:b:dec], peaks)
        fits.append((a, fit))
        rms.append(float(np.sqrt(fit.sse / fit.residual.size)))
    best = min(rms)
    ok = [j for j, r in enumerate(rms) if r <= max(2.0 * best, best + 3.0 * noise)]
    start, fit = fits[ok[0]]
    release = _last_rest_before(t[start], fit.freqs, fit.decays, fit.amplitudes, period)
    n_win = t.shape[0] - start
    decimation = max(1, int(np.ceil(n_win / MAX_WORK_SAMPLES)))
    return Window(start, decimation, hold, noise, max(release, float(t[0])), period)


def _last_rest_before(t_start: float, freqs: FloatArray, decays: FloatArray,
                      amps: NDArray[np.complex128], period: float) -> float:
    """Latest τ ∈ [-T/2, 0] where the main output's modal velocity is zero, as t_start + τ."""
    tau = np.linspace(-0.5 * period, 0.0, 400)
    main = int(np.argmax(np.abs(amps).sum(axis=1)))
    vel = np.zeros_like(tau)
    for j, (w, s) in enumerate(zip(freqs, decays)):
        a, b = amps[main, j].real, -amps[main, j].imag
        env = np.exp(-s * tau)
        vel += env * ((-s * a + w * b) * np.cos(w * tau) + (-s * b - w * a) * np.sin(w * tau))
    change = np.flatnonzero(np.sign(vel[1:]) != np.sign(vel[:-1]))
    if change.size == 0:
        return t_start
    i = int(change[-1])
    frac = vel[i] / (vel[i] - vel[i + 1])
    return float(t_start + tau[i] + frac * (tau[i + 1] - tau[i]))
