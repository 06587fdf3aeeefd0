"""The held cart's candidate: its measured motion as an input (smoothed), its coupling fitted
from a grid and several starts. No I/O here."""

from __future__ import annotations

import dataclasses

import numpy as np

from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem, best_on_grid

#: β values (in wn²) of the coupling's profile (`_profile_start`), and the function evaluations
#: of each profile point's fit of the release state and the rest.
PROFILE_BETAS = (0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.3)
PROFILE_NFEV = 8


def fit_held_cart(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                  typical: FloatArray, at: int, wn2: float, max_nfev: int) -> FitResult:
    """The held cart's coupling β fitted from the best of a grid at the current parameters,
    from 0.05, 0.2 and 0.5 wn², and from the best point of its profile (`_profile_start`), the
    best fit kept. The
    current model has absorbed the held cart's slow pull into its rest and frequency, so at
    those values any β > 0 costs more (a grid at fixed parameters picks β = 0) and a short
    fit from β = 0 does not find the joint move; from a start near the coupling it often does."""
    grid = best_on_grid(spec, prob, theta0, at, tuple(wn2 * g for g in (0.0, 0.05, 0.2, 0.5)))
    starts = [grid]
    for beta in (0.05 * wn2, 0.2 * wn2, 0.5 * wn2):
        start = grid.copy()
        start[at] = beta
        starts.append(start)
    profiled = _profile_start(spec, prob, theta0, lower, upper, typical, at)
    if profiled is not None:
        starts.append(profiled)
    best: FitResult | None = None
    for start in starts:
        result = fit(spec, start, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


def _profile_start(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                   typical: FloatArray, at: int) -> FloatArray | None:
    """The start of least cost on the coupling's profile: for each β of `PROFILE_BETAS` (in
    wn²), what the pull β·u does along the current model's own terms moved into them, and the
    release state and the rest refitted with everything else held. The held cart's motion u
    (least squares on the free cart's position x, velocity v, a smoothed sgn v and a constant:
    u ≈ f·x + g·v + h·sgn v + c; its follow, its lag behind the cart, and its hand's wander)
    acts as βf of stiffness, βg of damping, βh of dry friction and βc of rest: so the start has
    wn'² = wn² + βf, 2ζ'wn' = 2ζwn + βg, μ' = μ + βh and wn'²·rest' = wn²·rest - βc, the
    free response the current model had. A dry-friction cart that the wander drags from one
    stuck level to the next (red team `coulomb+held_cart` 9700, 73 Hz, a critically damped
    hand) shows the pull mostly there: the cost in β is a staircase of where it sticks, the
    fits from the starts above ended at β 1.6 times the true one, worse than no coupling, and
    the fit 1.85 points under its noise floor (from the profile: β 4 % off, at the floor).
    None for a model without the single cart's linear names or a held cart."""
    names = spec.names
    needed = ("wn_rad_s", "zeta", "x0_1_m", "v0_1_m_s", "rest_1_m")
    if prob.held is None or prob.y.shape[1] != 1 or any(n not in names for n in needed):
        return None
    iw, iz, ir = names.index("wn_rad_s"), names.index("zeta"), names.index("rest_1_m")
    im = names.index("coulomb_accel_m_s2") if "coulomb_accel_m_s2" in names else None
    x = prob.y[:, 0]
    v = np.gradient(x, prob.dt)
    sign = np.tanh(v / max(0.05 * float(np.max(np.abs(v))), 1e-12))
    follow, lag, dry, const = np.linalg.lstsq(np.column_stack([x, v, sign, np.ones(x.size)]), prob.held,
                                              rcond=None)[0]
    w = float(theta0[iw])
    state = ("x0_1_m", "v0_1_m_s", "rest_1_m")
    best: tuple[float, FloatArray] | None = None
    for g in PROFILE_BETAS:
        row = theta0.astype(np.float64).copy()
        beta = g * w * w
        w2n = w * w + beta * float(follow)
        if w2n <= 0.0:
            continue
        row[at], row[iw] = beta, np.sqrt(w2n)
        row[iz] = (2.0 * float(theta0[iz]) * w + beta * float(lag)) / (2.0 * float(row[iw]))
        row[ir] = (w * w * float(theta0[ir]) - beta * float(const)) / w2n
        if im is not None:
            row[im] = float(theta0[im]) + beta * float(dry)
        row = np.clip(row, lower, upper)
        fixed = dict(spec.fixed, **{n: float(row[i]) for i, n in enumerate(names) if n not in state})
        part = fit(dataclasses.replace(spec, fixed=fixed), row, lower, upper, typical, prob.dt, prob.y, prob.train,
                   max_nfev=PROFILE_NFEV)
        if best is None or part.sse_train < best[0]:
            best = (part.sse_train, part.theta)
    return None if best is None else np.asarray(best[1], dtype=np.float64)


#: Bins of the held reading's power spectrum averaged for the Wiener gain (odd).
HELD_SMOOTH_BINS = 9
#: The noise's power is subtracted this many times over: a margin for the averaged spectrum's
#: scatter (9 bins: a noise-only average exceeds 1.5 × its mean with p ≈ 0.05). 1, 1.5, 2, 3
#: tried on drawn held motions: 1.5 came nearest the ideal gain P_clean / (P_clean + σ²).
HELD_OVERSUBTRACT = 1.5


#: The held cart's ring on the hand, in multiples of the free cart's main mode, and its damping
#: ratio: the grid its follow of the free cart is fitted on (`held_follow`); "no ring" (a static
#: follow) is tried besides.
FOLLOW_RING_RATIOS = (2.0, 3.0, 5.0, 8.0, 13.0, 20.0)
FOLLOW_RING_ZETAS = (0.1, 0.3, 0.7)
#: The hand's wander is fitted as a cubic B-spline with knots this many main periods apart.
WANDER_PERIODS = 1.0
#: Phases of the lattice over which a staircase's error is averaged (`staircase_power`).
STAIRCASE_PHASES = 8


def held_input(reading: FloatArray, decimation: int) -> FloatArray:
    """The held cart's motion as the free cart's input (m, from its first work sample), on the
    work grid (every `decimation`-th sample of `reading` (N,) m), estimated from its reading
    alone (`held_motion` without the free cart's reading)."""
    return work_grid(held_motion(reading), decimation)


def work_grid(motion: FloatArray, decimation: int) -> FloatArray:
    """Every `decimation`-th sample of the held cart's `motion` (N,) m, from the first one."""
    work = np.asarray(motion, dtype=np.float64)[::decimation]
    out: FloatArray = work - work[0]
    return out


def held_motion(reading: FloatArray, free: FloatArray | None = None, dt: float = 0.0, wn: float = 0.0,
                quantum: float = 0.0) -> FloatArray:
    """The held cart's motion (N,) m estimated from its `reading` (N,) m.

    The input enters the fit multiplied by the coupling β = k2/m: a reading error e adds β e to
    the free cart's force, and least squares shrinks β by the share of the input's variance
    that is reading noise (errors in variables; generated flicks at 0.15 mm noise: β 7 % low,
    2.6 % with the noiseless held cart). What the held cart really does is a hand's slow
    wander, its pull by the free cart (the free cart's modes) and its own ring on the hand
    (a hand is a stiff spring: several times the free cart's frequency, excited by the
    release); no fixed cutoff keeps the ring and drops the noise at every rate (a low-pass at
    3 × the free cart's mode removed a held cart's 10 Hz ring at 57 Hz: β 6.3 % off, 0.2 %
    unfiltered).

    Most of the held cart's motion is its pull by the free cart, which the free cart's own
    reading gives far more precisely (it swings 10-70 times as far on the same encoder): with
    `free`, the held cart's motion is first fitted (least squares) as the free cart's reading
    through the held cart's ring on the hand, g ω_h²/(s² + 2 ζ_h ω_h s + ω_h²) (the best of
    `FOLLOW_RING_RATIOS` × `FOLLOW_RING_ZETAS`, and a static g), plus the hand's wander, a cubic
    B-spline with knots `WANDER_PERIODS` main periods apart. That pull is collinear with the
    free cart's own motion (its β is taken up by wn²): what fixes β is the rest, the wander.
    Read through a coarse lattice the pull's staircase has an amplitude-dependent error at
    the free cart's mode itself, where the resonance passes it on 1/(2ζ) times (red team
    `coulomb+held_cart` 2902, 1.37 mm counts: the reading's error through the free cart 2.3
    times the wander's own pull, β 53 % low; the friction of 2905 25 % off).

    What that fit leaves (the reading's error and whatever the fit missed) is passed through
    a zero-phase Wiener gain per frequency bin,

        G_k = max(0, 1 - c σ_k² / P̄_k),

    P̄_k the remainder's power |X_k|² averaged over `HELD_SMOOTH_BINS` bins, σ_k² the reading
    error's power in bin k: the larger of the white noise's (the median of |X_k|² over the
    upper half of the band divided by ln 2: |X_k|² of white noise is exponential, median =
    mean ln 2; a ring's few bins do not move a median) and, on an encoder lattice of quantum
    q, the power of the staircase error a lattice makes on the fitted motion
    (`staircase_power`: concentrated where the motion crosses few levels, not white),
    c = `HELD_OVERSUBTRACT`. The straight line between the ends is taken out first (the DFT is
    periodic: no jump at the wrap) and put back. Without `free` the whole reading is filtered
    so, against the white noise alone.
    """
    x = np.asarray(reading, dtype=np.float64)
    n = x.size
    if n < 8 * HELD_SMOOTH_BINS:
        return x.copy()
    fitted = np.zeros(n)
    if free is not None and dt > 0 and wn > 0:
        fitted = held_follow(x, np.asarray(free, dtype=np.float64), dt, wn)
    noise = staircase_power(fitted, quantum) if quantum > 0 and free is not None else None
    return _wiener(x - fitted, noise) + fitted


def held_follow(reading: FloatArray, free: FloatArray, dt: float, wn: float) -> FloatArray:
    """The held cart's pull by the free cart and the hand's slow wander fitted to its `reading`
    (N,) m (least squares; see `held_motion`): (N,) m, or zeros where the window is shorter
    than two wander knots."""
    import scipy.interpolate  # deferred: keeps `import ident` fast
    import scipy.signal
    n = reading.size
    end = (n - 1) * dt
    spacing = WANDER_PERIODS * 2.0 * np.pi / wn
    if end < 2.0 * spacing:
        return np.zeros(n)
    spans = int(np.ceil(end / spacing - 1e-9))
    edge = spans * spacing
    knots = np.concatenate([np.zeros(3), np.linspace(0.0, edge, spans + 1), np.full(3, edge)])
    wander = scipy.interpolate.BSpline.design_matrix(np.clip(dt * np.arange(n), 0.0, edge), knots, 3).toarray()
    # the wander's basis projected out once; each follow column is then one regressor
    basis, _ = np.linalg.qr(wander)
    target = reading - basis @ (basis.T @ reading)
    pulled = free - free[0]
    best: tuple[float, FloatArray] | None = None
    rings = [(0.0, 1.0)] + [(r * wn, z) for r in FOLLOW_RING_RATIOS for z in FOLLOW_RING_ZETAS
                             if r * wn < 0.8 * np.pi / dt]
    for w_h, zeta in rings:
        u = pulled
        if w_h > 0:
            b, a = scipy.signal.bilinear([w_h ** 2], [1.0, 2.0 * zeta * w_h, w_h ** 2], fs=1.0 / dt)
            u = scipy.signal.lfilter(b, a, pulled)
        u_perp = u - basis @ (basis.T @ u)
        norm = float(u_perp @ u_perp)
        if norm <= 0:
            continue
        g = float(u_perp @ target) / norm
        sse = float(np.sum((target - g * u_perp) ** 2))
        if best is None or sse < best[0]:
            best = (sse, g * u)
    follow = np.zeros(n) if best is None else best[1]
    rest = reading - follow
    fitted: FloatArray = follow + basis @ (basis.T @ rest)
    return fitted


def staircase_power(motion: FloatArray, quantum: float) -> FloatArray:
    """The power per DFT bin (as |rfft|², the line between the ends taken out) of the error a
    lattice of `quantum` (m) makes reading `motion` (N,) m, averaged over `STAIRCASE_PHASES`
    phases of the lattice and over `HELD_SMOOTH_BINS` bins."""
    from scipy.ndimage import uniform_filter1d  # deferred: keeps `import ident` fast
    n = motion.size
    ramp = np.arange(n, dtype=np.float64) / (n - 1)
    total = np.zeros(n // 2 + 1)
    for phase in (np.arange(STAIRCASE_PHASES) + 0.5) / STAIRCASE_PHASES * quantum:
        shifted = motion + phase
        error = quantum * np.round(shifted / quantum) - shifted
        error = error - (error[0] + (error[-1] - error[0]) * ramp)
        total += np.abs(np.fft.rfft(error)) ** 2
    out: FloatArray = uniform_filter1d(total / STAIRCASE_PHASES, HELD_SMOOTH_BINS, mode="nearest")
    return out


def _wiener(x: FloatArray, noise: FloatArray | None) -> FloatArray:
    """`x` (N,) through the zero-phase gain max(0, 1 - c σ_k²/P̄_k) (`held_motion`), σ_k² the
    larger of the white noise's power and `noise` (per bin, or None)."""
    from scipy.ndimage import uniform_filter1d  # deferred: keeps `import ident` fast
    n = x.size
    line = x[0] + (x[-1] - x[0]) * np.arange(n, dtype=np.float64) / (n - 1)
    spec = np.fft.rfft(x - line)
    power = np.abs(spec) ** 2
    noise_power = np.full(power.size, float(np.median(power[power.size // 2:])) / np.log(2.0))
    if noise is not None:
        noise_power = np.maximum(noise_power, noise)
    smooth = uniform_filter1d(power, HELD_SMOOTH_BINS, mode="nearest")
    gain = np.clip(1.0 - HELD_OVERSUBTRACT * noise_power / np.maximum(smooth, 1e-300), 0.0, 1.0)
    out: FloatArray = np.fft.irfft(spec * gain, n) + line
    return out


__all__ = ["fit_held_cart", "held_follow", "held_input", "held_motion", "staircase_power", "work_grid"]
