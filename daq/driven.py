"""Driven by the other cart: a cart's free response forced by the other carts' measured motion
through the coupling spring. Pure.

A ringing that fits driven across its would-be release was moved by a hand on the held cart,
not let go (`fits_across`), unless the other cart swings freely with it: then each cart of the
free pair is driven by the other's motion, and the hand let go where that stops holding
(`pair_release`); a hand that takes a cart of a running free pair breaks its own equation
(`still_free`); so does a hand that takes a single ringing cart.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares, lsq_linear

from daq.ringing import basis, even_clock, forced_response, friction_response, motion_sign

Array = npt.NDArray[np.float64]

# a driven fit's σ and ω are fitted on at most about this many samples of its window (a slide-back
# over seconds of a 1 kHz record fitted thousands: one feed took 7 s)
FIT_SAMPLES = 300
# the largest share of a cart's stiffness the coupling spring to the other cart may have in
# `fits_across` (1 when all of it: 1.25 leaves room for a spring fitted on a short window)
MAX_COUPLING_SHARE = 1.25
# a ringing is driven by the other cart when its free response driven by the other's measured
# motion fits across the release within DRIVEN_FIT times the ringing's own residual, and the
# other's motion takes the misfit of the free response alone below DRIVEN_EXPLAINS of it (a
# real 2025 flick, gently let go, fits 3.4 times its residual with it or without)
DRIVEN_FIT = 4.0
DRIVEN_EXPLAINS = 0.5
# a cart that rings alone (the other held) swings at the ringing's ω: its free response is sought
# within these multiples of it (`fits_across`, `still_free`: a strongly damped response at half
# the ω fitted a hand that caught the cart and held it)
ALONE_SPREAD = (0.8, 1.2)
# ... and it still moves as that free response while it misfits by less than this share of its
# span, RMS (`still_free`): a hand in the window misfit by 1.8-4.8 % (testkit students 6030,
# 6007, 6013, 6014), a free cart by 0.01-0.12 % (testkit students, real 2025 releases), one with
# an unmeasured second mode (red team `coupled_span` 1500: a pinned 0.75 kg cart beside a
# 2.8 kg one, one encoder) by 0.25-0.93 %
ALONE_LIMIT = 0.01
# a cart of a free pair, driven by the other's measured motion, swings at √((k_own + k_c)/m), not
# at one of the pair's modes: its ω is sought within these multiples of the ringing's (`pair_release`)
PAIR_SPREAD = (0.5, 3.0)
# ... and, sliding back, within this share of the last step's (`pair_release`)
PAIR_DRIFT = 0.05
# ... until a step misses by this many times its limit (`pair_release`)
PAIR_BREAK = 3.0
# ... and it stays its driven free response within DRIVEN_FIT times this share of its swing
# (RMS) until a hand takes a cart of the pair (`still_free`; as `release_dating.RING_FLOOR`)
PAIR_FLOOR = 0.0003


def fits_across(t: Array, y: Array, signs: Array, others: Array, t0_s: float, half_s: float, t_ref: float,
                spring: tuple[float, float]) -> tuple[float, float]:
    """RMS (m) of a free response fitted across the release, from a half-period before
    `date.t0_s` to 1.5 half-periods after: driven through the coupling spring by the other carts'
    measured motion (`others` (N, K) m, K may be 0), and alone; `signs` (N,) are the signs of
    the cart's measured velocity (`motion_sign`), for its dry friction. A released cart was held or
    swung by the hand before t0: no free response, however driven, follows it there, and both
    stay far above the ringing's own residual; a cart that a hand moving the held cart drove
    fits driven (`date_ringing` judges both against `DRIVEN_FIT` times that residual).

    The free cart obeys `x'' + 2σ x' + (σ² + ω²)(x - c - dτ) = Σ κ_k u_k(t) - μ sign(x')`, u_k the
    other carts' positions; each forced response `r_k` (from rest at the window's start,
    `forced_response`) joins the free model's columns with its own κ_k, the dry friction's with
    the signs of the cart's measured motion, and σ, ω are fitted again over the window (the
    ringing's, fitted later, left a touch of the held cart at 7-12 times the ringing's residual
    on a simulated student's record: a 1 % error in ω over a 13 mm forced swing). Each κ_k / Ω²
    is the coupling spring's share of the cart's stiffness, between 0 and `MAX_COUPLING_SHARE`
    (unbounded, the held cart's measured motion with a share of -51 mimicked the hand that
    flicked this one on a real ECP-210 record). With the ringing's spring, released carts had
    fitted 12-250 times the ringing's residual driven, driven ones 1.3-2.8 times (simulated and
    red-team records); refitted, that touch fits 0.67 times, and a real 2025 flick, gently let
    go, 3.4 times with or without the other cart (`DRIVEN_EXPLAINS` keeps it a release).
    """
    keep = (t >= t0_s - half_s) & (t <= t0_s + 1.5 * half_s)
    n = int(np.count_nonzero(keep))
    if n < 12:
        return math.inf, math.inf
    tw, yw, vw = even_clock(t[keep]), y[keep], signs[keep]
    u = others[keep].reshape(n, -1)

    def rms(k: int) -> float:
        fitted = _driven_fit(tw, yw, vw, u[:, :k], t_ref, spring, ALONE_SPREAD)
        return math.inf if fitted is None else float(np.sqrt(np.mean(fitted[0] ** 2)))

    alone = rms(0)
    return (rms(u.shape[1]) if u.shape[1] else alone), alone


def no_hand_before(t: Array, y: Array, signs: Array, others: Array, t0_s: float, half_s: float,
                   spring: tuple[float, float], floor_m: float) -> bool:
    """Whether a cart's free response driven by the other carts' motion (`others` (N, K)) holds
    across `t0_s` (from a half-period before it to 1.5 after, `fits_across`) within `DRIVEN_FIT`
    times its fit after t0 alone (at least `floor_m`): no hand held or moved the cart there. A
    free pair whose record starts in motion (testkit student 9709) fitted across the date its
    partner's slide-back gave (1.5 s after the start, where the long window's model of a cart
    that sticks and slips broke) at 0.5 times its residual after it; the partners a hand let go
    (testkit students 9000-9077 at 100 Hz, 26 releases) at 14-1400 times."""
    after = (t >= t0_s) & (t <= t0_s + 1.5 * half_s)
    if np.count_nonzero(after) < 12:
        return False
    tw = even_clock(t[after])
    fitted = _driven_fit(tw, y[after], signs[after], others[after], float(tw[0]), spring, ALONE_SPREAD)
    if fitted is None:
        return False
    own = max(float(np.sqrt(np.mean(fitted[0] ** 2))), floor_m)
    across, _ = fits_across(t, y, signs, others, t0_s, half_s, t0_s, fitted[1])
    return across <= DRIVEN_FIT * own


def _driven_fit(tw: Array, yw: Array, vw: Array, u: Array, t_ref: float, start: tuple[float, float],
                spread: tuple[float, float]) -> tuple[Array, tuple[float, float]] | None:
    """The residuals (n,) of the free response driven by the other carts' positions `u` (n, K)
    (`_driven_residual`), and its (σ, ω) fitted again from `start`, ω within `spread` times the
    start's (on every `n // FIT_SAMPLES`-th sample: the motion is smooth at that spacing); None
    when the fit fails."""
    sigma0, omega0 = start
    ts, ys, vs, us = _thinned(tw, yw, vw, u)
    try:
        fitted = least_squares(lambda p: _driven_residual(ts, ys, vs, us, t_ref, float(p[0]), float(p[1])),
                               np.array([sigma0, omega0]), max_nfev=40,
                               bounds=([0.0, spread[0] * omega0], [max(5.0 * sigma0, 2.0), spread[1] * omega0]))
    except (ValueError, np.linalg.LinAlgError):
        return None     # no fit: neither driven nor a swing that was going on
    sigma, omega = float(fitted.x[0]), float(fitted.x[1])
    residual = fitted.fun if ts.size == tw.size else _driven_residual(tw, yw, vw, u, t_ref, sigma, omega)
    return np.asarray(residual, dtype=np.float64), (sigma, omega)


def _thinned(tw: Array, yw: Array, vw: Array, u: Array) -> tuple[Array, Array, Array, Array]:
    """Every `n // FIT_SAMPLES`-th sample of a driven fit's window (all of a short one)."""
    k = max(1, tw.size // FIT_SAMPLES)
    return tw[::k], yw[::k], vw[::k], u[::k]


#: ω tried for the widest driven fit of a free pair's cart, multiples of the ringing's within
#: `PAIR_SPREAD` (from the ringing's ω alone, a strongly coupled pair's cart settled at 1.3 times
#: its true ω, and the slide-back, held within `PAIR_DRIFT` of it, broke 0.57 s after the let-go)
PAIR_GRID = tuple(float(f) for f in np.geomspace(PAIR_SPREAD[0], PAIR_SPREAD[1], 12))


def _widest_driven_fit(tw: Array, yw: Array, vw: Array, u: Array,
                       spring: tuple[float, float]) -> tuple[Array, tuple[float, float]] | None:
    """`_driven_fit` over ω within `PAIR_SPREAD` of `spring`'s, from the best ω of `PAIR_GRID`
    (each tried at `spring`'s σ, on the samples the fit uses)."""
    sigma0, omega0 = spring
    ts, ys, vs, us = _thinned(tw, yw, vw, u)
    misfit = [float(np.sum(_driven_residual(ts, ys, vs, us, float(tw[0]), sigma0, f * omega0) ** 2))
              for f in PAIR_GRID]
    f = PAIR_GRID[int(np.argmin(misfit))]
    lo, hi = PAIR_SPREAD
    return _driven_fit(tw, yw, vw, u, float(tw[0]), (sigma0, f * omega0), (lo / f, hi / f))


def _driven_residual(tw: Array, yw: Array, vw: Array, u: Array, t_ref: float, sigma: float, omega: float) -> Array:
    """The residuals (n,) of `x'' + 2σ x' + (σ² + ω²)(x - c - dτ) = Σ κ_k u_k(t) - μ sign(x')`
    fitted linearly (`fits_across`; each coupling's share κ_k / Ω² between 0 and
    `MAX_COUPLING_SHARE`)."""
    k = u.shape[1]
    bounds = (np.r_[np.full(5, -np.inf), np.zeros(k)], np.r_[np.full(5, np.inf), np.full(k, MAX_COUPLING_SHARE)])
    g1, g2, _, _ = basis(tw, t_ref, sigma, omega)
    columns = [np.ones_like(tw), tw - t_ref, friction_response(tw, vw, sigma, omega), g1, g2]
    columns += [forced_response(tw, u[:, j] - u[0, j], sigma, omega) for j in range(k)]
    return _bounded_residual(np.stack(columns, axis=1), yw, *bounds)


def _bounded_residual(a: Array, y: Array, lo: Array, hi: Array) -> Array:
    """The residuals `a x - y` of the least-squares x within [lo, hi]: the unbounded solution
    when it lies within them, else by BVLS. Not scipy's default `trf`: its line search never
    ends on a rank-deficient `a` (a cart that moves one way over the window makes dry
    friction's response a sum of the other columns: a feed at the end of a record hung)."""
    x = np.linalg.lstsq(a, y, rcond=None)[0]
    if not (np.all(x >= lo) and np.all(x <= hi)):
        x = lsq_linear(a, y, bounds=(lo, hi), method="bvls").x
    out: Array = a @ x - y
    return out


def pair_release(t: Array, y: Array, signs: Array, others: Array, t0_s: float, half_s: float,
                 spring: tuple[float, float], floor_m: float,
                 t_limit: float) -> tuple[float, tuple[float, float]] | None:
    """Where a hand let go of a cart that swings freely with another: each one's motion is then
    its free response driven by the other's, so a ringing confirmed a while after its release
    fits driven wherever it was dated. That driven free response, fitted on [t0, t0 + 1.5
    half-periods] (t0 = `t0_s`; the driven cart swings at √((k_own + k_c)/m), not at one of
    the pair's modes: ω within `PAIR_SPREAD` of the ringing's, `spring` = (σ, ω)), is slid back in eighths of a
    half-period, σ and ω fitted again at each step (held from the first fit, a slide over
    seconds drifts off and stops anywhere), while every residual of its first quarter
    half-period stays within `DRIVEN_FIT` times the first fit's RMS (at least `floor_m`), until
    a step misses by `PAIR_BREAK` times that: a hand (on testkit students a hand missed by 4.8-42
    times, an input read coarsely, the other cart flicked at 50 Hz, by 1-2.3); the release is
    where it stops fitting, to a 64th of a half-period, with the (σ, ω) of the last fit that
    held (for `daq.joined.date_pair`'s finer date). `-inf` when the slide reaches
    `t_limit` (no hand in view: the cart the hand never touched); None when a fit fails."""
    end = t0_s + 1.5 * half_s
    limit = math.inf

    def fits_from(ts: float, factor: float = 1.0) -> bool | None:
        nonlocal spring, limit
        window = (t >= ts) & (t <= end)
        if np.count_nonzero(window) < 12:
            return None
        tw = even_clock(t[window])
        yw, vw, uw = y[window], signs[window], others[window]
        # after the first fit ω stays within `PAIR_DRIFT` of the last (left within `PAIR_SPREAD`
        # at every step, it absorbed a hand's push, and a flick at 50 Hz was slid back to 0.3 s
        # before its let-go), unless that misses and the widest fit holds: on a short first
        # window several ω fit as well, and the slide from the wrong one broke before the hand
        def drift() -> tuple[Array, tuple[float, float]] | None:
            return _driven_fit(tw, yw, vw, uw, float(tw[0]), spring, (1.0 - PAIR_DRIFT, 1.0 + PAIR_DRIFT))

        def widest() -> tuple[Array, tuple[float, float]] | None:
            return _widest_driven_fit(tw, yw, vw, uw, spring)

        for fit in (drift, widest) if math.isfinite(limit) else (widest,):
            fitted = fit()
            if fitted is None:
                return None
            r, found = fitted
            if not math.isfinite(limit):
                limit = DRIVEN_FIT * max(float(np.sqrt(np.mean(r ** 2))), floor_m)
            if float(np.max(np.abs(r[tw <= tw[0] + half_s / 4.0]))) <= factor * limit:
                spring = found
                return True
        return False

    if not fits_from(t0_s):
        return None
    step, start = half_s / 8.0, t0_s
    while start - step >= t_limit:
        fits = fits_from(start - step, PAIR_BREAK)
        if fits is None:
            return None
        if not fits:
            for _ in range(3):      # to an eighth of the step
                step /= 2.0
                if fits_from(start - step):
                    start -= step
            return start, spring
        start -= step
    return -math.inf, spring


def still_free(t: Array, pos: Array, channels: list[int], spring: tuple[float, float], min_swing_m: float,
               paired: bool) -> bool:
    """Whether each of `channels` (the carts that swing freely) still moves over (`t` (N,) s,
    `pos` (N, C) m: a period) as its free response driven by the other carts' measured motion (a
    free pair's partner, or a loosely held cart's wander), σ and ω fitted again from `spring`.
    A cart of a free pair (`paired`) swings at √((k_own + k_c)/m), ω within `PAIR_SPREAD`, and
    its model is whole: within `PAIR_BREAK` × `DRIVEN_FIT` times `PAIR_FLOOR` of the largest span
    there, RMS (a hand misses by far more, as in `pair_release`); a cart that rings alone,
    ω within `ALONE_SPREAD`, may carry a mode no encoder reads: within `ALONE_LIMIT` of it. Not
    judged when no cart spans `min_swing_m` (the limit would be the noise); the largest span, not
    each cart's own: a pair's beating takes one cart down to millimetres. A hand that takes one
    of them breaks its own equation at once (not the other's: that one stays driven by whatever
    the held cart does); a pair's own beating breaks neither, nor does a held cart's wander."""
    span = max((float(np.ptp(pos[:, c])) for c in channels), default=0.0)
    if t.size < 12 or span < min_swing_m:
        return True
    spread, limit = (PAIR_SPREAD, PAIR_BREAK * DRIVEN_FIT * PAIR_FLOOR) if paired else (ALONE_SPREAD, ALONE_LIMIT)
    tw = even_clock(t)
    for channel in channels:
        y = pos[:, channel]
        fitted = _driven_fit(tw, y, motion_sign(t, y), np.delete(pos, channel, axis=1), float(t[0]), spring, spread)
        if fitted is not None and float(np.sqrt(np.mean(fitted[0] ** 2))) > limit * span:
            return False
    return True
