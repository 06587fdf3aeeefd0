"""Free ringing of one channel: turning points, the ringing test, and where the ringing began.

Pure numerics for the release detector (`daq.detector`), no state beyond one channel's
turning points. A released cart rings: it swings about a centre with half-periods that
repeat and swings that do not grow. A hand does not: a nudge goes out and comes back once,
a slow pull or a held cart's wander is too small or too irregular. So a release is confirmed
by its ringing, and then dated by where a free response starts to fit.

Turning points (`Zigzag`). A turn is recorded once the position retreats from its running
extreme by more than `band_m` (hysteresis above the noise and the tremor). Its time is the
end of the plateau at the extreme (the last sample within `band_m / 2` of it), so a hold
followed by a release turns where the hand lets go, not somewhere inside the hold. `swings`
asks the same of a stretch with a band of a quarter of its span: out and back at least once.

Ringing test (`is_ringing`) on the last three turns A, B, C (times tA < tB < tC, positions):
half-periods `B - A` and `C - B` within `[min_half_s, max_half_s]` and within a factor
`half_ratio` of each other, the swing `|C - B| >= min_swing_m`, and it does not grow:
`|C - B| <= grow |B - A| + 2 band_m`. A flick from rest gives A = the rest, B near the
release, and its first swing is partial (so the test passes one turn later, on B, C, D).

Where the ringing began: a damped sinusoid about a drifting centre with dry friction
`x(t) = c + d τ + f R(t) + e^{-στ} (A cos ωτ + B sin ωτ)`, τ = t - t_ref, R the response to
friction's force against the motion (`FreeFit`; `fit_free`: σ, ω by least squares, c, d, f,
A, B linear), is fitted on three quarters of a period from a quarter half-period after the
middle turn B (after any release near B) on, and slid back in time while the data keep
following it (`slide_back`). The fine instant is `daq.release_dating`'s.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares
from scipy.signal import cont2discrete, lfilter, ss2tf

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Turn:
    """A turning point: `t_s` the end of the plateau at the extreme, `x_m` the extreme."""

    t_s: float
    x_m: float


class Zigzag:
    """Turning points of one channel with hysteresis `band_m` (m); the last `keep` are kept."""

    def __init__(self, band_m: float, keep: int = 8) -> None:
        self.band_m = band_m
        self.turns: deque[Turn] = deque(maxlen=keep)
        self._direction = 0           # +1 rising, -1 falling, 0 not known yet
        self._ext_x = math.nan        # running extreme of the current direction
        self._ext_end_t = 0.0         # last time within band/2 of it
        self._lo = self._hi = math.nan
        self._lo_t = self._hi_t = 0.0

    def clear(self) -> None:
        """Forget every turn and the direction (the next sample starts afresh)."""
        self.turns.clear()
        self._direction = 0
        self._ext_x = self._lo = self._hi = math.nan

    def keep_last(self, n: int) -> None:
        """Forget all turns but the last `n` (what came before belongs to another motion)."""
        while len(self.turns) > n:
            self.turns.popleft()

    def push(self, t_s: float, x: float) -> bool:
        """One sample; True when it completed a new turn (appended to `turns`)."""
        band = self.band_m
        d = self._direction
        if d == 0:
            return self._push_unknown(t_s, x)
        ext = self._ext_x
        if (x - ext) * d >= 0.0:          # still going the same way: a new extreme
            self._ext_x, self._ext_end_t = x, t_s
            return False
        if abs(x - ext) <= 0.5 * band:
            self._ext_end_t = t_s
            return False
        if abs(x - ext) <= band:
            return False
        self.turns.append(Turn(self._ext_end_t, ext))
        self._direction = -d
        self._ext_x, self._ext_end_t = x, t_s
        return True

    def _push_unknown(self, t_s: float, x: float) -> bool:
        if math.isnan(self._lo):
            self._lo = self._hi = x
            self._lo_t = self._hi_t = t_s
            return False
        self._lo = min(self._lo, x)
        self._hi = max(self._hi, x)
        if abs(x - self._lo) <= 0.5 * self.band_m:
            self._lo_t = t_s
        if abs(x - self._hi) <= 0.5 * self.band_m:
            self._hi_t = t_s
        if x - self._lo > self.band_m:
            self.turns.append(Turn(self._lo_t, self._lo))
            self._direction = 1
        elif self._hi - x > self.band_m:
            self.turns.append(Turn(self._hi_t, self._hi))
            self._direction = -1
        else:
            return False
        self._ext_x, self._ext_end_t = x, t_s
        return True


def swings(t: Array, y: Array) -> bool:
    """Whether `y` goes out and comes back by a quarter of its span (a hand that pushes a cart
    smoothly one way fits a free response over a window as well as a swing does)."""
    zigzag = Zigzag(0.25 * float(np.ptp(y)))
    return sum(zigzag.push(float(ti), float(yi)) for ti, yi in zip(t, y)) >= 2


@dataclass(frozen=True, slots=True)
class RingingLimits:
    """What counts as ringing: swing (m), half-period bounds (s), consistency, growth."""

    min_swing_m: float
    min_half_s: float
    max_half_s: float
    half_ratio: float = 1.5
    grow: float = 1.15
    band_m: float = 0.0


def is_ringing(a: Turn, b: Turn, c: Turn, limits: RingingLimits) -> bool:
    """True when the turns A, B, C (oldest first) look like a free swing (see module)."""
    h1, h2 = b.t_s - a.t_s, c.t_s - b.t_s
    if not (limits.min_half_s <= h1 <= limits.max_half_s and limits.min_half_s <= h2 <= limits.max_half_s):
        return False
    if max(h1, h2) > limits.half_ratio * min(h1, h2):
        return False
    s1, s2 = abs(b.x_m - a.x_m), abs(c.x_m - b.x_m)
    return s2 >= limits.min_swing_m and s2 <= limits.grow * s1 + 2.0 * limits.band_m


def is_broken(a: Turn, b: Turn, c: Turn, limits: RingingLimits) -> bool:
    """A swing that grew or a half-period that changed: not the same free ringing any more."""
    s1, s2 = abs(b.x_m - a.x_m), abs(c.x_m - b.x_m)
    h1, h2 = b.t_s - a.t_s, c.t_s - b.t_s
    return s2 > limits.grow * s1 + 2.0 * limits.band_m or max(h1, h2) > limits.half_ratio * min(h1, h2)


@dataclass(frozen=True, slots=True)
class FreeFit:
    """A damped sinusoid about a drifting centre, with dry friction, τ = t - t_ref:
    `c + d τ + f R(t) + e^{-στ} (A cos ωτ + B sin ωτ)`. The drift: a held cart's slow wander
    moves the free cart's rest through the spring. `f = F_c / k` (m): Coulomb friction is a
    force against the motion, and `R` is the cart's response to it, from rest at `t_ref`
    (`friction_response`): each half swing then rings about a centre shifted by `f` against
    its motion with position and velocity continuous at the turns, so the swing shrinks by
    2f a half-period (a centre that jumps at each turn, `-f sgn v`, is not a motion: on a
    strongly damped ringing it fitted f < 0 and stopped the slide-back a half-period late).
    Evaluated on samples from `t_ref` on."""

    t_ref: float
    sigma: float      # 1/s
    omega: float      # rad/s (damped)
    coef: tuple[float, float, float, float, float]   # c (m), d (m/s), f (m), A, B (m)
    rms_m: float

    def __call__(self, t: Array, vsign: Array) -> Array:
        g1, g2, _, _ = basis(t, self.t_ref, self.sigma, self.omega)
        c, d, f, a, b = self.coef
        friction = friction_response(t, vsign, self.sigma, self.omega)
        out: Array = c + d * (t - self.t_ref) + f * friction + a * g1 + b * g2
        return out


def motion_sign(t: Array, y: Array) -> Array:
    """sgn(v) of a sampled position (shapes (N,)), as a force that switches between samples:
    ±1 while the cart moves, and across a turn a ramp over ±1 sample centred where the
    velocity (central differences) passes zero, so that the input taken linear between
    samples switches at that instant, not at the nearest sample (at 100 Hz half a sample of
    dry friction's force on the wrong side changes the swing by F_c·dt/(kω): 0.4 mm on a
    strongly damped cart)."""
    n = y.size
    if n < 3:
        return np.zeros_like(y)
    v = np.empty(n)
    v[1:-1] = (y[2:] - y[:-2]) / (t[2:] - t[:-2])
    v[0], v[-1] = v[1], v[-2]
    change = np.empty(n)
    change[1:-1] = 0.5 * np.abs(v[2:] - v[:-2])
    change[0], change[-1] = change[1], change[-2]
    out: Array = np.clip(v / np.maximum(change, 1e-300), -1.0, 1.0)
    return out


def forced_response(t: Array, u: Array, sigma: float, omega: float) -> Array:
    """Response (N,) of `x'' + 2σx' + Ω²x = Ω² u(t)` (Ω² = σ² + ω²) from rest at t[0] to `u`
    sampled at `t` (N,), linear between samples (exact for that input, on a uniform grid of
    the median spacing). From rest means x = x' = 0 at t[0] whatever u[0] is: the filter's zero
    state would have the input ramp up to u[0] over the step before t[0], so it takes u - u[0]
    and the step response to u[0] is added; a response is then the same on every prefix of `t`."""
    if t.size < 2:
        return np.zeros_like(t)
    step = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1] + 0.5 * step, step)
    num, den = _foh_filter(sigma, omega, step)
    ug = np.interp(grid, t, u)
    tau = grid - grid[0]
    from_rest = 1.0 - np.exp(-sigma * tau) * (np.cos(omega * tau) + sigma / omega * np.sin(omega * tau))
    out = lfilter(num, den, ug - ug[0]) + ug[0] * from_rest
    response: Array = np.interp(t, grid, out)
    return response


@lru_cache(maxsize=256)
def _foh_filter(sigma: float, omega: float, step: float) -> tuple[Array, Array]:
    """(numerator, denominator) of `forced_response`'s system discretized for an input linear
    between samples `step` apart (the joined model asks for one σ, ω hundreds of times)."""
    om2 = sigma ** 2 + omega ** 2
    a = np.array([[0.0, 1.0], [-om2, -2.0 * sigma]])
    b = np.array([[0.0], [om2]])
    ad, bd, cd, dd, _ = cont2discrete((a, b, np.array([[1.0, 0.0]]), np.zeros((1, 1))), step, method="foh")
    num, den = ss2tf(ad, bd, cd, dd)
    return np.asarray(num[0], dtype=np.float64), np.asarray(den, dtype=np.float64)


def friction_response(t: Array, vsign: Array, sigma: float, omega: float) -> Array:
    """The response (N,) to dry friction's force against the motion, `-Ω² sgn v` per unit of
    `f`, from rest at t[0]: settles at -1 while the cart moves one way (`forced_response`)."""
    return forced_response(t, -vsign, sigma, omega)


def basis(t: Array, t_ref: float, sigma: float, omega: float) -> tuple[Array, Array, Array, Array]:
    """e^{-στ} cos ωτ, e^{-στ} sin ωτ and their time derivatives, τ = t - t_ref."""
    tau = t - t_ref
    env = np.exp(-sigma * tau)
    cos, sin = np.cos(omega * tau), np.sin(omega * tau)
    g1, g2 = env * cos, env * sin
    return g1, g2, -sigma * g1 - omega * g2, -sigma * g2 + omega * g1


def fit_free(t: Array, y: Array, vs: Array, sigma0: float, omega0: float, spread: float = 0.4) -> FreeFit | None:
    """Least-squares `FreeFit` on (t, y, sgn v) (shapes (N,)), σ in [0, ω], ω within ±`spread`."""
    if t.size < 6:
        return None
    t_ref = float(t[0])

    def linear(params: Array) -> tuple[Array, Array]:
        g1, g2, _, _ = basis(t, t_ref, float(params[0]), float(params[1]))
        friction = friction_response(t, vs, float(params[0]), float(params[1]))
        design = np.stack([np.ones_like(t), t - t_ref, friction, g1, g2], axis=1)
        coef = np.asarray(np.linalg.lstsq(design, y, rcond=None)[0], dtype=np.float64)
        residual: Array = y - design @ coef
        return coef, residual

    lo = np.array([0.0, (1.0 - spread) * omega0])
    hi = np.array([max(omega0, 1e-6), (1.0 + spread) * omega0])
    start = np.clip(np.array([sigma0, omega0]), lo, hi - 1e-9)
    try:
        result = least_squares(lambda p: linear(p)[1], start, bounds=(lo, hi), x_scale=np.array([1.0, omega0]))
    except (ValueError, np.linalg.LinAlgError):
        return None
    coef, residual = linear(result.x)
    rms = float(np.sqrt(np.mean(residual ** 2)))
    return FreeFit(t_ref, float(result.x[0]), float(result.x[1]),
                   (float(coef[0]), float(coef[1]), float(coef[2]), float(coef[3]), float(coef[4])), rms)


def refit_linear(t: Array, y: Array, vs: Array, sigma: float, omega: float) -> FreeFit | None:
    """`FreeFit` on (t, y, sgn v) with σ and ω given: only c, d, f, A, B are fitted."""
    if t.size < 6:
        return None
    t_ref = float(t[0])
    g1, g2, _, _ = basis(t, t_ref, sigma, omega)
    design = np.stack([np.ones_like(t), t - t_ref, friction_response(t, vs, sigma, omega), g1, g2], axis=1)
    coef = np.linalg.lstsq(design, y, rcond=None)[0]
    rms = float(np.sqrt(np.mean((y - design @ coef) ** 2)))
    return FreeFit(t_ref, sigma, omega, (float(coef[0]), float(coef[1]), float(coef[2]), float(coef[3]),
                                          float(coef[4])), rms)


def slide_back(t: Array, y: Array, vs: Array, t_from: float, span_s: float, half_s: float, first: FreeFit,
               t_limit: float, floor_m: float = 0.0, k_rms: float = 4.0) -> tuple[float, FreeFit]:
    """Slide a free-response window `[ts, ts + span_s]` back from `t_from` in steps of
    `half_s / 8` while it still fits with ω within ±4 % of `first`'s (the fit at `t_from`; a
    hand's push is not absorbed by a changed frequency): its RMS within 1.5 × and every residual of
    its first eighth of a period within `k_rms` × the RMS of `first`, not before `t_limit`; that
    RMS taken at least `floor_m` (a few samples' RMS is a poor yardstick at low rates) and at least
    half `first`'s largest residual: a free response the model misses by structure (a held cart's
    weak second mode, a rest that drifts) leaves residuals that peak at turns at several times
    their RMS, and the window's head, sliding over a turn, is judged by what the free response
    itself shows there, not taken for the hand (it stopped flicks a half-period late).
    Returns the earliest start that fits and its fit."""
    start, fit = t_from, first
    step = half_s / 8.0
    own = (t >= t_from) & (t <= t_from + span_s)
    peak = float(np.max(np.abs(y[own] - first(t[own], vs[own])))) if own.any() else 0.0
    ref = max(first.rms_m, floor_m, 0.5 * peak)
    limit = k_rms * ref
    while start - step >= t_limit:
        ts = start - step
        window = (t >= ts) & (t <= ts + span_s)
        trial = fit_free(t[window], y[window], vs[window], fit.sigma, first.omega, spread=0.04)
        if trial is None or trial.rms_m > 1.5 * ref:
            break
        head = (t >= ts) & (t <= ts + half_s / 4.0)   # none at a coarse rate's fast ring: nothing to judge
        if head.any() and np.max(np.abs(y[head] - trial(t[head], vs[head]))) > limit:
            break
        start, fit = ts, trial
    return start, fit


def even_clock(t: Array) -> Array:
    """The sample times of a window, evened out when the device stamps a coarse clock on evenly
    taken samples (the ECP-210 stamps whole ms on ~1.13 ms samples: ±0.5 ms, ±0.3 mm at speed):
    a straight line through (index, t) when every stamp lies within half a spacing of it (no
    sample missing), else the stamps as they are."""
    if t.size < 3:
        return t
    k = np.arange(t.size, dtype=np.float64)
    slope, intercept = np.polyfit(k, t, 1)
    line: Array = intercept + slope * k
    return line if float(np.max(np.abs(t - line))) < 0.5 * slope else t


def spring_of(turns: tuple[Turn, Turn, Turn]) -> tuple[float, float]:
    """(σ 1/s, ω rad/s) of a ringing from its turns A, B, C: ω = π / half-period, σ from the
    swings' decay (0 when the second swing is not smaller)."""
    a, b, c = turns
    half = 0.5 * (c.t_s - a.t_s)
    s1, s2 = abs(b.x_m - a.x_m), abs(c.x_m - b.x_m)
    sigma = max(0.0, math.log(max(s1, 1e-12) / max(s2, 1e-12)) / half) if s2 < s1 else 0.0
    return sigma, math.pi / half


def centre_of(turns: tuple[Turn, Turn, Turn]) -> float:
    """Where a ringing swings about, from its turns A, B, C: (A + 2B + C) / 4, exact under dry
    friction's linear decay and to first order under viscous decay."""
    a, b, c = turns
    return 0.25 * (a.x_m + 2.0 * b.x_m + c.x_m)
