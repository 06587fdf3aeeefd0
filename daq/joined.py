"""The joined model of a release: a hand's force that ends at t0 joined to the free response
after it, t0 by least squares. Pure.

    t >= t0:  x = f(t)
    t <  t0:  x = f(t) + F_r d1(t - t0) + S d2(t - t0) + Q d3(t - t0)

is the free motion (`daq.ringing.FreeFit`: a damped sinusoid about a drifting centre with dry
friction; for a cart of a free pair also driven by the other carts' measured motion) plus the
cart's response to a hand force `F_r + S (t0 - t) + Q (t0 - t)²` that ends at t0 (over the
`HAND_WINDOW` of a half-period before it; `hand_response`, ≈ F_r τ²/2 + S τ³/6 + Q τ⁴/12);
linear in the free coefficients and the hand's for a given t0, t0 by a grid an eighth of a
sample apart, then finer. The hand's force is curved: a hand that carries the cart along its
path and lets go near the path's end pushes with what keeps the cart on the path, which bends
over the last tenth of a second (a straight force dated such flicks 1-3 samples early): the
curve is taken where the positions clearly ask for it (`CURVE_F`). A cart of a free pair keeps
the straight force (`PAIR_HAND_TERMS`). A quartic position (an earlier
model, no spring) also followed the first free samples and dated real flicks 8-29 ms late.
`daq.release_dating` finds the coarse instant this refines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from daq.ringing import FreeFit, basis, even_clock, forced_response, friction_response

Array = npt.NDArray[np.float64]

# the hand's force is fitted over this fraction of a half-period before the release, after its
# peak (real flicks: 30-100 ms before let-go, 0.15-0.5 half-period); over 0.3 the peak entered
# the window and dated flicks up to 25 ms early
HAND_WINDOW = 0.2
# ... and over at least this many samples (the line's, the free response's and the noise's) ...
HAND_MIN_SAMPLES = 5
# ... or, where those samples reach back across the push's peak, over this many: a 50 Hz flick
# pushes for 5-10 samples (red team 3302: three flicks slid back to within a sample of the
# let-go, then dated 1.1-2.1 samples early by the joined fit over 5). The shorter window is
# taken when dropping the samples before it gains in an F test at this level (α): 50 Hz flicks
# along a hand's path (tests/daq/test_release_dating.py's draw), within one sample 81 -> 84 / 85
# and 80 -> 84 / 87 of 96 in two sets at α = 0.001 / 0.01; none changed at 100 Hz. Taken always,
# it dated the daq's own 50 Hz students no better (91 -> 90 of 96 within one sample; at 0.01, 91)
HAND_SHORT_SAMPLES = 3
HAND_SHORT_ALPHA = 0.01
# ... as a polynomial in time of this many terms (constant, slope, curve: `hand_response`) ...
HAND_TERMS = 3
# ... the curve taken only where the straight force (these many terms) leaves the positions
# clearly worse: an F statistic of the curve's gain against the curved fit's residual variance
# above this (α ≈ 0.001 for one term). A curve taken on weaker evidence follows a force that
# fades towards the let-go and places t0 late: at F > 2 the daq's own simulated students at
# 100 Hz (their hand lets go at 0.5-2.5 m/s²) went from 100 to 96.2 % of the releases in the
# data within one sample (+1.3 to +2.2 samples, F 2.3-13.7), here 99.6 %; the red team's flicks
# along a hand's path, where the line dates 1-3 samples early, show F 10-190 (50 of 57 within one
# sample at F > 2, 48 here, 42 with the line). On a straight force ending at once
# (tests/daq/test_release_dating.py) the curve, fitted always, dated a 50 Hz release 1.7
# samples late at F = 0.01
STRAIGHT_TERMS = 2
CURVE_F = 11.0
# ... and, for a cart of a free pair (`date_pair`), a straight line: there the other cart's
# forced response, fitted beside it, trades with the curve (testkit 11216: a free pair's
# partner "released" 0.1 s later, where a hand took the cart, 2.26 s)
PAIR_HAND_TERMS = 2
# a free pair's cart is dated (`date_pair`) on a free response fitted this many half-periods past
# the hand's window after the coarse date (the lone one's 0.5 left the coupling's coefficient free
# to trade with the hand's: a free pair's flicks dated 10-20 ms early at 1 kHz), t0 sought this
# many hand windows before and after it (the driven slide stops where its fit breaks, anywhere
# within its last step, an eighth of a half-period, of the let-go)
PAIR_AFTER = 1.0
PAIR_SEARCH = (1.0, 1.5)


@dataclass(frozen=True, slots=True)
class ReleaseDate:
    """Where the free response begins: `t0_s`, the spring's acceleration there, the fit."""

    t0_s: float
    accel_m_s2: float
    free: FreeFit


def date_pair(t: Array, y: Array, signs: Array, others: Array, t_coarse: float, half_s: float,
              spring: tuple[float, float]) -> float:
    """Fine release instant of a cart of a free pair near `t_coarse` (`pair_release`'s, a 64th
    of a half-period apart and where the slid fit stops holding, which it does a little inside
    the hand's push): the joined model with the free response driven by the other carts'
    measured motion `others` (N, K) (`date_release`'s `drive`), (σ, ω) = `spring` from the
    driven fit. `t_coarse` when that fit fails or its best instant lies at the edge of the
    search, within a sample of it (no let-go the joined model finds: a cart that stuck and
    slipped under dry friction after its let-go was dated 0.18 s later there)."""
    free = FreeFit(t_coarse, spring[0], spring[1], (0.0, 0.0, 0.0, 0.0, 0.0), 0.0)
    date = date_release(t, y, signs, free, t_coarse, half_s, drive=others, after=PAIR_AFTER, search=PAIR_SEARCH,
                        hand_terms=PAIR_HAND_TERMS)
    if date is None:
        return t_coarse
    step, back = _hand_window(t, half_s)
    inside = t_coarse - PAIR_SEARCH[0] * back + step < date.t0_s < t_coarse + PAIR_SEARCH[1] * back - step
    return date.t0_s if inside else t_coarse


def _hand_window(t: Array, half_s: float) -> tuple[float, float]:
    """(the sample period, how long before the release the hand's force is fitted) (s)."""
    step = float(np.median(np.diff(t)))
    return step, max(HAND_WINDOW * half_s, HAND_MIN_SAMPLES * step)


def date_release(t: Array, y: Array, vs: Array, free: FreeFit, t_coarse: float, half_s: float,
                 drive: Array | None = None, after: float = 0.5,
                 search: tuple[float, float] = (0.5, 0.75), hand_terms: int = HAND_TERMS) -> ReleaseDate | None:
    """Fine release instant near `t_coarse`: a hand force ending at t0 (a line, or a curve where
    it gains F > `CURVE_F`) joined to the free response (module docstring); shapes (N,). Fitted
    over [t_coarse - w, t_coarse + w + `after` half-periods], w the hand's window, t0 sought over
    [t_coarse - `search[0]` w, t_coarse + `search[1]` w]. With `drive` (N, K), the other carts'
    measured positions, the free response is driven by them through the coupling spring (a free
    pair's cart, `daq.driven`): their forced responses join the free columns. At most
    `hand_terms` (1-3) of the hand's force (`hand_response`) are fitted."""
    step, back = _hand_window(t, half_s)
    hi = t_coarse + back + after * half_s
    fitted = _joined_fit(t, y, vs, free, t_coarse, (back, hi), step, drive, search, hand_terms)
    if fitted is not None and HAND_WINDOW * half_s < HAND_MIN_SAMPLES * step:
        # the window the sample minimum set may hold the push's peak: without the samples
        # before the last `HAND_SHORT_SAMPLES`, does the hand's force fit significantly better?
        short = _joined_fit(t, y, vs, free, t_coarse, (HAND_SHORT_SAMPLES * step, hi), step, drive, search,
                            hand_terms, search_from=t_coarse - search[0] * back)
        if short is not None and short.fits_better_than(fitted, HAND_SHORT_ALPHA):
            fitted = short
    if fitted is None:
        return None
    tw, yw, vw, forced, best, terms = fitted.tw, fitted.yw, fitted.vw, fitted.forced, fitted.t0_s, fitted.terms
    coef, _ = _joint_solve(tw, yw, vw, free, best, None, forced, terms)
    g1, g2, d1, d2 = basis(np.array([best]), free.t_ref, free.sigma, free.omega)
    # the spring's acceleration at t0, from the ODE x'' = -2σ x' - (σ² + ω²)(x - c)
    x_rel = coef[3] * g1[0] + coef[4] * g2[0]
    v = coef[3] * d1[0] + coef[4] * d2[0]
    accel = -2.0 * free.sigma * v - (free.sigma ** 2 + free.omega ** 2) * x_rel
    refit = FreeFit(free.t_ref, free.sigma, free.omega,
                    (float(coef[0]), float(coef[1]), float(coef[2]), float(coef[3]), float(coef[4])), free.rms_m)
    return ReleaseDate(float(best), abs(float(accel)), refit)


@dataclass(frozen=True)
class _Joined:
    """The joined model's best t0 over one window: the window's samples (even clock), the
    forced columns, t0, the hand's terms, the RSS and the parameters fitted."""

    tw: Array
    yw: Array
    vw: Array
    forced: Array | None
    t0_s: float
    terms: int
    rss: float
    params: int

    def fits_better_than(self, longer: _Joined, alpha: float) -> bool:
        """Whether the samples `longer` has before this window's first cost it significantly:
        F = ((RSS_long - RSS) / m) / (RSS / dof) against F(m, dof) at level `alpha` (freeing
        the m samples leaves this window's fit)."""
        import scipy.stats  # deferred: keeps `import daq` fast
        m = longer.tw.size - self.tw.size
        dof = self.tw.size - self.params
        if m <= 0 or dof <= 0 or self.rss <= 0.0:
            return False
        f = ((longer.rss - self.rss) / m) / (self.rss / dof)
        return bool(f > float(scipy.stats.f.ppf(1.0 - alpha, m, dof)))


def _joined_fit(t: Array, y: Array, vs: Array, free: FreeFit, t_coarse: float, window: tuple[float, float],
                step: float, drive: Array | None, search: tuple[float, float], hand_terms: int,
                search_from: float | None = None) -> _Joined | None:
    """`date_release`'s fit over [t_coarse - back, hi] (`window` = (back, hi)), t0 sought from
    `search_from` (default t_coarse - `search[0]` back) to t_coarse + `search[1]` back; None
    when the window is too short or holds no candidate."""
    back, hi = window
    keep = (t >= t_coarse - back) & (t <= hi)
    tw, yw, vw = even_clock(t[keep]), y[keep], vs[keep]
    if tw.size < 10:
        return None
    forced = (np.stack([forced_response(tw, u, free.sigma, free.omega) for u in drive[keep].T], axis=1)
              if drive is not None and drive.shape[1] else None)
    # the RSS has a local minimum between every two samples: the coarse grid must be finer
    # than the sample spacing, or it lands in the wrong interval
    first = t_coarse - search[0] * back if search_from is None else search_from
    candidates = np.arange(first, t_coarse + search[1] * back, step / 8.0)
    candidates = candidates[(candidates > tw[2]) & (candidates < tw[-4])]
    if candidates.size == 0:
        return None

    def least(terms: int) -> tuple[float, float]:
        """(t0, RSS) of the joined model with `terms` of the hand's force."""
        best = _best_joint(tw, yw, vw, free, candidates, forced, terms)
        best = _best_joint(tw, yw, vw, free, np.linspace(best - step / 8.0, best + step / 8.0, 25), forced, terms)
        return best, _joint_solve(tw, yw, vw, free, best, None, forced, terms)[1]

    columns = 5 + (0 if forced is None else forced.shape[1])
    terms = min(hand_terms, STRAIGHT_TERMS)
    best, rss = least(terms)
    if hand_terms > terms:
        curved, rss_curved = least(hand_terms)
        dof = tw.size - columns - hand_terms
        if rss - rss_curved > CURVE_F * (hand_terms - terms) * rss_curved / max(dof, 1):
            best, terms, rss = curved, hand_terms, rss_curved
    return _Joined(tw, yw, vw, forced, best, terms, rss, columns + terms + 1)


def hand_response(s: Array, sigma: float, omega: float) -> tuple[Array, Array, Array]:
    """What a hand force that ends at s = 0 adds to the free motion before it, s = t - t0 ≤ 0 (N,).

    d'' + 2σ d' + (σ² + ω²) d = h(s), d(0) = d'(0) = 0 (the hand lets go: position and velocity
    are continuous), for h = 1, -s and s² (m/s² per unit; Ω² = σ² + ω²): d = P + e^{-σs} (A cos
    ωs + B sin ωs), P the polynomial that solves the equation, A = -P(0), B = (σA - P'(0))/ω:

        h = 1:    P = 1/Ω²                                       d1 ≈ s²/2
        h = -s:   P = -s/Ω² + 2σ/Ω⁴                              d2 ≈ -s³/6
        h = s²:   P = s²/Ω² - 4σs/Ω⁴ + (8σ² - 2Ω²)/Ω⁶            d3 ≈ s⁴/12

    The spring acts on the hand's push too: over the 0.2-0.3 half-period the hand is fitted, ω²s²
    reaches ~1, and the bare polynomials α s² + β s³ would date the release ~1 ms early.
    """
    om2 = sigma ** 2 + omega ** 2
    env = np.exp(-sigma * s)
    cos, sin = np.cos(omega * s), np.sin(omega * s)

    def joined(p: Array, p0: float, dp0: float) -> Array:
        a = -p0
        out: Array = p + env * (a * cos + (sigma * a - dp0) / omega * sin)
        return out

    d1 = joined(np.full_like(s, 1.0 / om2), 1.0 / om2, 0.0)
    d2 = joined(-s / om2 + 2.0 * sigma / om2 ** 2, 2.0 * sigma / om2 ** 2, -1.0 / om2)
    c3 = (8.0 * sigma ** 2 - 2.0 * om2) / om2 ** 3
    d3 = joined(s ** 2 / om2 - 4.0 * sigma * s / om2 ** 2 + c3, c3, -4.0 * sigma / om2 ** 2)
    return d1, d2, d3


def _joint_solve(t: Array, y: Array, vs: Array, free: FreeFit, t0: float, friction: dict[int, Array] | None = None,
                 forced: Array | None = None, hand_terms: int = HAND_TERMS) -> tuple[Array, float]:
    """Coefficients (c, d, f, A, B, then the hand's `hand_terms` (scaled), then one per `forced`
    column) and RSS of the joined model for one `t0`; `friction` caches the friction column by
    the first sample at or after t0 (it depends on nothing else)."""
    g1, g2, _, _ = basis(t, free.t_ref, free.sigma, free.omega)
    k0 = min(int(np.searchsorted(t, t0)), t.size - 1)
    col_f = friction.get(k0) if friction is not None else None
    if col_f is None:
        # dry friction goes on pulling against the motion the cart has just before t0 while
        # the hand acts (whole: the hand moves the cart; `vs` ramps only across a free turn)
        before = np.sign(vs[max(k0 - 1, 0)])
        col_f = friction_response(t, np.where(np.arange(t.size) < k0, before, vs), free.sigma, free.omega)
        if friction is not None:
            friction[k0] = col_f
    hands = [h / max(float(np.max(np.abs(h))), 1e-300)      # scaled for conditioning
             for h in hand_response(np.minimum(t - t0, 0.0), free.sigma, free.omega)[:hand_terms]]
    design = np.stack([np.ones_like(t), t - free.t_ref, col_f, g1, g2, *hands], axis=1)
    if forced is not None:
        design = np.concatenate([design, forced], axis=1)
    coef = np.asarray(np.linalg.lstsq(design, y, rcond=None)[0], dtype=np.float64)
    residual = y - design @ coef
    return coef, float(residual @ residual)


def _best_joint(t: Array, y: Array, vs: Array, free: FreeFit, candidates: Array, forced: Array | None,
                hand_terms: int) -> float:
    friction: dict[int, Array] = {}
    rss = [_joint_solve(t, y, vs, free, float(c), friction, forced, hand_terms)[1] for c in candidates]
    return float(candidates[int(np.argmin(rss))])
