"""Where a hand acts: the force on a cart that its free equation of motion does not explain.

A free cart obeys (per unit mass, the other free carts' positions entering through springs)

    a_j = -Σ_i k_ji x_i - c_j v_j - f_j·sgn(v_j) + b_j - d_j·w|w|,

with stiffness `k`, viscous `c` and dry friction `f` (m/s²; sgn smoothed as the derivatives
are, `friction_sign`, so that the regression stays linear), an offset `b` (the rest position)
and quadratic drag, which a linear model lacks (`state_terms`, w = v/speed). The coefficients
come from a robust regression (Tukey bisquare, iteratively reweighted) of the smoothed
acceleration on those terms over the samples where the cart moves: hand phases are short
and get weight zero. The residual `r_j` is then the hand's force per unit mass: large while
a hand pulls, holds, flicks or moves the cart (or, through the spring, a held cart it is
coupled to), near zero during a free response. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.releases.motion import FloatArray, Motion, accel_noise, moving_samples, typical_speed
from ident.releases.unread import coupling_holds, hidden_mode, mass_candidates

#: Tukey bisquare tuning constant (95 % efficiency for Gaussian residuals).
TUKEY_C = 4.685
#: A residual beyond this many robust scales is a hand.
HAND_SIGMAS = 6.0
#: Near a stop (a reversal, or the cart stuck) dry friction is anywhere between -f_s and
#: +f_s (static, up to ~1.3× the kinetic f) and flips there; the smoothed sgn(v) regressor
#: places the flip only roughly, so the residual may reach f + f_s there without a hand:
#: that much (in units of the fitted kinetic f) is allowed on top of the noise.
STICK_ALLOWANCE = 2.5
#: ... and this fraction of the modelled acceleration |a| is model error, not a hand (a hand
#: that lets a cart go held it with a force comparable with the spring's: far above it).
MODEL_FRACTION = 0.02
#: A fit of a cart alone whose k_jj lies outside this range of the record's ringing
#: ω² = (2π/T)² is not its free motion (`_best_fit`).
STIFFNESS_RANGE = (0.25, 4.0)
#: A free response's own misfit (`state_misfit`): this many times the record's median share
#: of the swing's acceleration, at most this share (a hand that lets a cart go held it with
#: at least `judge.HAND_FORCE_FRACTION` of the spring's force).
STATE_MISFIT_FACTOR = 2.0
STATE_MISFIT_CAP = 0.25
#: ... counting only what |r| exceeds this many residual scales by (the noise is not a force).
NOISE_SHARE = 1.0
#: A cart alone (no other cart read) may pull an unread mass through a spring (`unread`): the
#: mass is taken when it divides what the free model's robust residual scale has beyond the
#: acceleration's noise (root of the difference of squares) by at least this (the real
#: records' one-cart fits: at most 1.26; an unread cart: 1.8-7) ...
HIDDEN_GAIN = 1.5
#: ... and the scale itself drops below this fraction of the free model's (near the noise a
#: small drop is a large one of the excess: a one-cart flick, 0.84 -> 0.78 m/s² beside 0.75 of
#: noise, had lost its release).
HIDDEN_SCALE_DROP = 0.8


@dataclass(frozen=True)
class FreeModel:
    """The fitted free equation of motion of one cart (see the module docstring).

    `column` the cart's column; `others` the columns whose positions enter; `stiffness`
    (len(others)+1,) k_jj first (1/s²); `viscous` c_j (1/s); `dry` f_j (m/s²); `offset` b_j
    (m/s²); `v_smooth` v_s (m/s); `residual` (N,) m/s²; `scale` its robust std over the
    free samples; `hand` (N,) bool, where |residual - drift| > HAND_SIGMAS·scale + allowance
    (`drift`); `slow` the columns of `others` entering by their period average (held carts);
    `allowance` (N,) m/s² the error allowed: dry friction near a stop (`near_stop`) and
    `MODEL_FRACTION` of the modelled acceleration; `push_allowance` (N,) the same with dry
    friction at the reversals of a swinging cart only (`near_reversal`): a push may start a
    cart from rest. Both include the free response's own misfit (`state_misfit`). `extra`
    (1,) the state term's coefficient (m/s²) with its `speed` (m/s), then (2,) the
    coefficients of the `hidden` mode's regressors (N, 2) when the cart pulls an unread mass
    (`hidden_mode`).
    """

    column: int
    others: tuple[int, ...]
    stiffness: FloatArray
    viscous: float
    dry: float
    offset: float
    v_smooth: float
    residual: FloatArray
    scale: float
    hand: NDArray[np.bool_]
    slow: tuple[int, ...] = ()
    allowance: FloatArray | None = None
    push_allowance: FloatArray | None = None
    extra: FloatArray | None = None
    speed: float = 1.0
    hidden: FloatArray | None = None

    @property
    def wn(self) -> float:
        """Natural frequency of the cart alone (rad/s)."""
        return float(np.sqrt(max(float(self.stiffness[0]), 1e-12)))

    @property
    def static_stiffness(self) -> float:
        """What a hand holding the cart still holds it against (1/s²): k_jj less an unread
        mass's pull κ (`hidden`: the mass comes to rest with the cart, z = x_j, and its spring,
        part of k_jj, then pulls nothing). A stiff spring to a light mass counted whole made a
        hold's force look too weak for a release (`testkit.effects` coupled_mode 9988548: k_jj
        576 /s², of which the mass's pull κ 347)."""
        k = float(self.stiffness[0])
        if self.hidden is not None and self.extra is not None:
            k -= float(self.extra[1])
        return max(k, 1e-12)

    def rest(self, others_x: FloatArray | None = None) -> float:
        """Spring equilibrium (m) for given other positions (none: zeros)."""
        load = 0.0 if others_x is None or not self.others else float(self.stiffness[1:] @ others_x)
        return (self.offset - load) / max(float(self.stiffness[0]), 1e-12)


def regressors(m: Motion, column: int, others: tuple[int, ...], v_smooth: float,
               slow: tuple[int, ...] = (), speed: float | None = None,
               hidden: FloatArray | None = None) -> FloatArray:
    """The regression matrix (N, 4 + len(others)): -x_j, -x_others, -v_j, -tanh(v_j/v_s), 1,
    then the state term (with `speed`) and the `hidden` mode's columns (N, 2), if given.

    A column in `slow` (a held cart) enters by its average over one period: where the hand
    holds it (its wander, or a touch that moves it), not its weak following of this cart,
    which is nearly proportional to x_j and would make the regression ill-posed."""
    cols = [-m.x[:, column]] + [-(period_average(m, m.x[:, i]) if i in slow else m.x[:, i]) for i in others]
    cols += [-m.v[:, column], -friction_sign(m, column, v_smooth), np.ones(m.n_samples)]
    if speed is not None:
        cols += state_terms(m, column, speed)
    if hidden is not None:
        cols += list(hidden.T)
    return np.column_stack(cols)


def state_terms(m: Motion, column: int, speed: float) -> list[FloatArray]:
    """The smooth force of the state a linear free model lacks, as a regressor (N,): quadratic
    drag -w|w| (w = v/`speed`, order one): an effect present all along a free response and
    decaying with it, which a hand's force (not a function of the state) is not. (A spring
    curved in x, x² and x³ terms, also took a real cart's sub-millimetre creep near a stop
    for a push.)"""
    w = m.v[:, column] / speed
    return [-w * np.abs(w)]


def friction_sign(m: Motion, column: int, v_smooth: float) -> FloatArray:
    """sgn(v_j) as the smoothed acceleration sees it: the sign of the velocity (tanh over
    `v_smooth` against noise) passed through the same Savitzky–Golay filter, so that a dry
    friction force flipping at a velocity zero is blurred in the regressor as in the data."""
    from scipy.signal import savgol_filter  # deferred: keeps `import ident` fast
    sign = np.tanh(m.v[:, column] / v_smooth)
    if m.window >= m.n_samples:
        return np.asarray(sign, dtype=np.float64)
    return np.asarray(savgol_filter(sign, m.window, 3, mode="interp"), dtype=np.float64)


def period_average(m: Motion, x: FloatArray) -> FloatArray:
    """`x` (N,) averaged over one period (centred; the ends use the samples there are)."""
    width = m.samples(m.period_s)
    kernel = np.ones(width)
    total = np.convolve(x, kernel, mode="same")
    count = np.convolve(np.ones_like(x), kernel, mode="same")
    return np.asarray(total / count, dtype=np.float64)


def fit_free_model(m: Motion, column: int, others: tuple[int, ...] = (),
                   slow: tuple[int, ...] = (), unread: bool = True) -> FreeModel:
    """Robust fit of the free equation of motion of `column` (see the module docstring);
    the `slow` columns among `others` enter by their period average (`regressors`). A spring
    to another cart is part of this cart's own stiffness (|k_ji| <= k_jj): a fit that breaks
    that (a short record where a held cart's average says nothing) is redone without them.
    A cart alone (no free cart read beside it) is fitted with an unread mass too, when
    `unread` (the better of `unread.mass_candidates`), kept when it divides the residual's scale beyond the noise
    by `HIDDEN_GAIN` and the scale itself by 1 / `HIDDEN_SCALE_DROP`: a second cart or mass
    coupled to it and not read (a one-encoder record of two carts) rings in its free response.
    A mass taken is searched and fitted again let go from wherever it was where the cart
    begins to move (`let_go_refit`)."""
    model = _fit(m, column, others, slow)
    k = model.stiffness
    if slow and any(abs(float(k[1 + others.index(i)])) > abs(float(k[0])) for i in slow if i in others):
        kept = tuple(i for i in others if i not in slow)
        model = _fit(m, column, kept, ())
    if not unread or any(i not in model.slow for i in model.others):
        return model
    # (the reading noise itself: at 50 Hz a cart's ringing set the usual estimate 20 times
    # over, above the free model's whole residual, and the search for a 3.6 Hz second cart was
    # skipped as within the noise: red team `coupled_pinned` 9800, its hold's let-go then
    # dated 3 samples late)
    noise = accel_noise(m, column, ringing=True)

    def excess(scale: float) -> float:
        return float(np.sqrt(max(scale ** 2 - noise ** 2, 0.0)))

    # (strictly: a residual within the noise either way gains nothing, so a free model within
    # it needs no search; and near the noise a small drop of the scale is a large one of its
    # excess: the scale itself must drop too)
    if excess(model.scale) == 0.0:
        return model
    base = regressors(m, column, model.others, model.v_smooth, model.slow, model.speed)
    candidates = mass_candidates(m, column, base)
    fits = [_fit(m, column, model.others, model.slow, c.regressors) for c in candidates]
    if not fits:
        return model
    best = int(np.argmin([f.scale for f in fits]))
    other = fits[best]
    assert other.extra is not None   # the state term's coefficient, then the hidden mode's (κ first)
    if coupling_holds(float(other.extra[1]), float(other.stiffness[0])) \
            and excess(model.scale) > HIDDEN_GAIN * excess(other.scale) \
            and other.scale <= HIDDEN_SCALE_DROP * model.scale:
        return let_go_refit(m, column, other, base)
    return model


def let_go_refit(m: Motion, column: int, model: FreeModel, base: FloatArray) -> FreeModel:
    """The unread mass of `model` (taken) searched and fitted again let go from wherever it was
    where the cart begins to move (`unread.let_go_modes`), then refitted once with the mass's
    dry friction flipping where its velocity changes sign as that fit has it (driven by the
    cart and let go where the modes put it: their part of the pull over its position's
    coefficient κ), not as the cart alone drives it; `model` where the mass no longer pulls
    as a spring can. `hidden_mode` from rest took the mass to have followed the cart: a hand
    that holds it at its own rest while it holds the cart off its rest (a hold of two carts
    read through one encoder, let go together) left the first swing misfit by 5-13 % of the
    hold's force, and the mass, swinging back towards the cart while G·x_j follows the cart
    away, had its friction's share the wrong way round; the fine residual stayed over its
    limit and the release was dated late (red team `two_cart_coulomb_y1` 3702, 56 Hz: 5.2
    samples; 3831, 456 Hz, f₂ 1.7 m/s²: 16). The refit is kept where its scale is at most
    `model`'s (a robust scale over the whole record weighs the first swing little: the
    friction's refit raised 3831's from 0.108 to 0.121 m/s², below the 0.133 without the
    modes), and where the mass's motion from the let-go stays within the cart's whole range
    (a mass let go further from where the model has it is the modes fitting something else:
    a motor pulse's step, red team `coulomb+force_pulse` 402, 3.4 times, lost both its
    releases). Only once the mass is taken
    (`base` (N, p) the free model's regressors): the modes fit a one-cart record's first swing
    too, and with them in the search that decides whether to take a mass one was taken and the
    release lost in 3 of 48 red-team one-cart records (seeds 8-11)."""
    candidates = mass_candidates(m, column, base, let_go=True)
    fits = [_fit(m, column, model.others, model.slow, c.regressors) for c in candidates]
    if not fits:
        return model
    best = int(np.argmin([f.scale for f in fits]))
    out, mass = fits[best], candidates[best]
    assert out.extra is not None and out.hidden is not None
    kappa = float(out.extra[1])
    if not coupling_holds(kappa, float(out.stiffness[0])):
        return model
    # extra: the state term, κ, the friction share, then the let-go modes (hidden's columns 2:)
    let_go = out.hidden[:, 2:] @ out.extra[3:] / kappa
    if float(np.max(np.abs(let_go))) > float(np.ptp(m.x[:, column])):
        return model
    again = _fit(m, column, model.others, model.slow, hidden_mode(m, column, mass.wn, mass.zeta, None, let_go))
    assert again.extra is not None
    refit = again if coupling_holds(float(again.extra[1]), float(again.stiffness[0])) else out
    return refit if refit.scale <= model.scale else model


def _fit(m: Motion, column: int, others: tuple[int, ...], slow: tuple[int, ...],
         hidden: FloatArray | None = None) -> FreeModel:
    v = m.v[:, column]
    speed = typical_speed(v)
    v_smooth = max(0.02 * speed, 3.0 * float(m.noise_m[column]) / m.dt / 10.0, 1e-9)
    basis = regressors(m, column, others, v_smooth, slow, max(speed, 1e-9), hidden)
    target = m.a[:, column]
    moving = moving_samples(v, speed)
    if np.count_nonzero(moving) < basis.shape[1] * 4:
        moving = np.ones(m.n_samples, dtype=bool)
    n_k = 1 + len(others)
    # (with a hidden mode this cart's own stiffness is its spring's and the coupling's, far
    # from the ringing's ω² when the unread mass is heavy)
    alone = hidden is None and all(i in slow for i in others)
    coef, scale = _physical_fit(m, basis, target, moving, n_k, alone)
    resid = target - basis @ coef
    # and a small share of the modelled force: the free model is fitted on the whole record,
    # so its error grows with the swing (a cart swinging further than most of the record)
    model_error = MODEL_FRACTION * np.abs(basis @ coef)
    stick = STICK_ALLOWANCE * abs(float(coef[n_k + 1]))
    stops = stick * near_stop(m, column, v_smooth)
    hand = _hand(m, resid, HAND_SIGMAS * scale + stops + model_error)
    # the free response's own misfit, from the samples the first pass leaves free: beyond the
    # noise for single samples (the hand's limit has the noise already), all of it for the
    # sustained pushes' moving average (which averages the noise out)
    spring = basis[:, :n_k] @ coef[:n_k] + coef[n_k + 2]
    free = moving & ~hand
    allowance = stops + np.maximum(model_error, state_misfit(m, column, spring, float(coef[0]), resid, free,
                                                             NOISE_SHARE * scale))
    hand = _hand(m, resid, HAND_SIGMAS * scale + allowance)
    push_allowance = stick * near_reversal(m, column, v_smooth) + np.maximum(
        model_error, state_misfit(m, column, spring, float(coef[0]), resid, free, 0.0))
    return FreeModel(column, others, np.asarray(coef[:n_k]), float(coef[n_k]), float(coef[n_k + 1]),
                     float(coef[n_k + 2]), v_smooth, resid, scale, hand, slow, allowance,
                     push_allowance, np.asarray(coef[n_k + 3:]), max(speed, 1e-9), hidden)


def _hand(m: Motion, resid: FloatArray, limit: FloatArray) -> NDArray[np.bool_]:
    """Where |residual - drift| exceeds `limit` (N,)."""
    return np.asarray(np.abs(resid - drift(resid, np.abs(resid) > limit, m.samples(2.0 * m.period_s))) > limit)


def state_misfit(m: Motion, column: int, spring: FloatArray, k: float, resid: FloatArray,
                 free: NDArray[np.bool_], noise: float) -> FloatArray:
    """The misfit (N,) m/s² a free response carries along, in proportion to its swing: the
    record's typical share q of the swing's acceleration e = √(a_s² + k·v²) (a_s the spring's
    acceleration, k = ω², so e = ω²·A for a swing of amplitude A), q the median of
    max(|r| - noise, 0)/e over the `free` samples where e is at least a quarter of its 95th
    percentile, times `STATE_MISFIT_FACTOR`, at most `STATE_MISFIT_CAP`: an effect the
    free model lacks (a second mode, a force curved in x or v) is a function of the state,
    present all along a free response and decaying with it; a hand's force is not."""
    env = np.sqrt(spring ** 2 + max(k, 0.0) * m.v[:, column] ** 2)
    big = free & (env > 0.25 * float(np.percentile(env, 95)))
    if np.count_nonzero(big) < 10:
        return np.zeros_like(resid)
    # beyond the noise (scale): a coarse encoder's noise is not a force of the state
    share = float(np.median(np.maximum(np.abs(resid[big]) - noise, 0.0) / env[big]))
    return np.asarray(min(STATE_MISFIT_CAP, STATE_MISFIT_FACTOR * share) * env, dtype=np.float64)


def _physical_fit(m: Motion, basis: FloatArray, target: FloatArray, moving: NDArray[np.bool_],
                  n_k: int, alone: bool = False) -> tuple[FloatArray, float]:
    """`_best_fit`, refitted without viscous or dry friction while the fit makes either
    negative (a force along the motion is no friction: a short record whose hand pulled the
    cart slowly for as long as it rang can buy such a fit of the pull)."""
    keep = list(range(basis.shape[1]))
    while True:
        part, scale = _best_fit(m, basis[:, keep], target, moving, alone)
        coef = np.zeros(basis.shape[1])
        coef[keep] = part
        negative = [i for i in (n_k, n_k + 1) if i in keep and coef[i] < 0.0]
        if not negative:
            return coef, scale
        keep.remove(negative[-1])


def _best_fit(m: Motion, basis: FloatArray, target: FloatArray, moving: NDArray[np.bool_],
              alone: bool = False) -> tuple[FloatArray, float]:
    """The robust fit (`_irls`) from all moving samples, or from the inliers of the best
    least-squares fit on one stretch of 1.5 periods (least median of |residual| over the
    moving samples), whichever leaves the smaller median |residual|: a short record with a
    long pull or hold drags a fit started from every sample off the free motion, while a
    stretch of free motion fits the rest of the free motion. A cart `alone` (no other free
    cart's position enters) rings at its own frequency: a fit whose k_jj lies outside
    `STIFFNESS_RANGE` of the record's ω² is not its free motion (two free carts' modes may
    lie far from either cart's own frequency)."""
    wn2 = (2.0 * np.pi / m.period_s) ** 2

    def spread(c: FloatArray) -> float:
        # a cart's own stiffness (column 0) far from the ringing's ω² explains a slow pull,
        # not the free motion (a run file that ends on a long pull-hold)
        if alone and not STIFFNESS_RANGE[0] <= float(c[0]) / wn2 <= STIFFNESS_RANGE[1]:
            return np.inf
        return float(np.median(np.abs(target - basis @ c)[moving]))

    coef, scale = _irls(basis, target, moving, moving)
    best, best_spread = coef, spread(coef)
    # (a stretch has at least 5 samples per coefficient: at 50 Hz a period may have 8)
    least = 5 * basis.shape[1]
    widths = sorted({max(m.samples(f * m.period_s), least) for f in (1.5, 0.75)}, reverse=True)
    for width, lo in [(w, lo) for w in widths for lo in range(0, max(1, m.n_samples - w + 1), max(1, w // 2))]:
        part = np.zeros(m.n_samples, dtype=bool)
        part[lo:lo + width] = True
        part &= moving
        if np.count_nonzero(part) < 4 * basis.shape[1]:
            continue
        c = np.asarray(np.linalg.lstsq(basis[part], target[part], rcond=None)[0], dtype=np.float64)
        if spread(c) < best_spread:
            best, best_spread = c, spread(c)
    if best is coef:
        return coef, scale
    start = moving & (np.abs(target - basis @ best) < 3.0 * best_spread)
    if np.count_nonzero(start) < 4 * basis.shape[1]:
        return coef, scale
    other, other_scale = _irls(basis, target, moving, start)
    return (other, other_scale) if spread(other) < spread(coef) else (coef, scale)


def _irls(basis: FloatArray, target: FloatArray, moving: NDArray[np.bool_], start: NDArray[np.bool_]
          ) -> tuple[FloatArray, float]:
    """Tukey-bisquare regression of `target` on `basis` over the `moving` samples, from a
    least-squares fit on the `start` samples: (coefficients, robust residual scale)."""
    weights = start.astype(np.float64)
    coef: FloatArray = np.zeros(basis.shape[1])
    scale = 0.0
    for _ in range(12):
        w = np.sqrt(weights)
        coef = np.asarray(np.linalg.lstsq(basis * w[:, None], target * w, rcond=None)[0], dtype=np.float64)
        resid = target - basis @ coef
        scale = float(np.median(np.abs(resid[moving & (weights > 0)]))) / 0.6745 if np.any(weights > 0) else 0.0
        scale = max(scale, 1e-12)
        u = resid / (TUKEY_C * scale)
        weights = np.where(moving & (np.abs(u) < 1.0), (1.0 - u ** 2) ** 2, 0.0)
    return coef, scale


def near_stop(m: Motion, column: int, v_smooth: float) -> FloatArray:
    """1.0 (N,) within a smoothing window of where the cart reverses (v changes sign), stops
    or starts again (|v| crosses a few `v_smooth`), else 0.0: where dry friction flips and the
    smoothed sgn(v) places the flip only roughly. Not through a long stop: a stuck cart's
    friction force is steady there (a constant the drift takes), and a hand or a spring that
    moves it from rest must still be seen."""
    v = m.v[:, column]
    stop = np.abs(v) < 3.0 * v_smooth
    change = np.zeros(v.size, dtype=bool)
    change[1:] = (np.signbit(v[1:]) != np.signbit(v[:-1])) | (stop[1:] != stop[:-1])
    width = 2 * m.window + 1
    spread = np.convolve(change.astype(np.float64), np.ones(width), mode="same") > 0.5
    return np.asarray(spread, dtype=np.float64)


def near_reversal(m: Motion, column: int, v_smooth: float) -> FloatArray:
    """1.0 (N,) within a smoothing window of where a swinging cart reverses: v changes sign
    with |v| beyond 3 `v_smooth` within a window before (not a resting cart's noise). Not
    necessarily after: a cart whose spring barely beats static friction at its last turn
    creeps back slowly and sticks (red team record 311: 0.5 mm in 90 ms, the residual at the
    kinetic friction f there), and that last turn is no push either."""
    v = m.v[:, column]
    w = m.window
    fast = np.abs(v) > 3.0 * v_smooth
    hits = np.flatnonzero(np.signbit(v[1:]) != np.signbit(v[:-1])) + 1
    keep = [i for i in hits if np.any(fast[max(0, i - w):i])]
    mark = np.zeros(v.size, dtype=np.float64)
    mark[keep] = 1.0
    spread = np.convolve(mark, np.ones(2 * w + 1), mode="same") > 0.5
    return np.asarray(spread, dtype=np.float64)


def drift(resid: FloatArray, hand: NDArray[np.bool_], width: int) -> FloatArray:
    """The slow part of the residual outside the hand's episodes (N,): a running median over
    `width` samples of the samples not flagged, held across the flagged ones. A held cart
    moved to a new place shifts the pulled cart's rest for good; that shift is not a hand on
    the pulled cart (the sustained-push test sees the move itself)."""
    keep = np.flatnonzero(~hand)
    if keep.size < 3:
        return np.zeros_like(resid)
    step = max(1, width // 8)
    centres = keep[::step]
    half = width // 2
    values = np.array([np.median(resid[keep[(keep >= c - half) & (keep <= c + half)]]) for c in centres])
    return np.asarray(np.interp(np.arange(resid.size), centres, values), dtype=np.float64)
