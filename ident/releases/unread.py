"""An unread mass that a cart read alone pulls through a spring: a second cart on one encoder,
or a light mass pinned by a spring (`hand.fit_free_model` takes it into the cart's free
equation when it fits). The mass moves only through the spring, so its position is the
cart's through a driven oscillator, whatever the hand does on the cart; its frequency and
damping are searched. No I/O.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.releases.motion import FloatArray, Motion, moving_samples

#: The mass's frequency with the cart held is searched over these multiples of the ringing's ω
#: (below half the Nyquist frequency), 3 % apart (a lightly damped mass's misfit has a valley a
#: few per cent wide in frequency: a red-team two-cart record at 907 Hz, robust scale 0.43 m/s²
#: at 1.65 ω, 2.8 at 1.58), and these damping ratios ...
HIDDEN_RATIOS = tuple(float(r) for r in np.geomspace(0.25, 6.0, 109))
HIDDEN_DAMPING = (0.005, 0.03, 0.15)
#: ... first every this many of those ratios, then all of them around the best this many
#: minima of the coarse ones ...
HIDDEN_COARSE_STEP = 4
HIDDEN_VALLEYS = 3
#: ... on a record with at least this many moving samples (8 per coefficient of the extended
#: model, 5 + 2: a two-cart flick that friction stops in a second at 59-84 Hz has 60-84), at
#: most this many of them, evenly spread (a 1 kHz record's smoothed acceleration changes little
#: from one sample to the next) ...
HIDDEN_MIN_MOVING = 56
HIDDEN_SEARCH_SAMPLES = 2000
#: ... each candidate fitted by least squares and again on this share of the samples, those it
#: fits best (`HIDDEN_TRIMS` concentration steps of a least-trimmed-squares fit from the plain
#: one): the hand's phase, which no free model follows (a flick from rest is a fifth of a
#: one-second ringing's samples), drags a plain fit off the free motion. (Trimmed to the samples
#: within three robust scales of the plain fit instead, it stayed dragged where the flick is
#: large: red team `two_cart_coulomb_y1` seed 6, median |residual| 2.2 m/s² at the unread cart's
#: frequency against 0.46 trimmed to the best 60 %, and no release was found in 3 of 24 records.
#: Started from either half of the moving samples as well, it found seed 1106's mass, whose
#: slow push the trimmed plain fit keeps, but took `coupled_pinned` 19's 5 % off the true
#: frequency, fitting its pull and late ringing and not its first cycles: dated 21 samples late.)
HIDDEN_KEEP = 0.6
HIDDEN_TRIMS = 4
#: A cart that rests (or is held) for at least this share of a period, then moves as long,
#: lets the unread mass go from wherever it was (`motion_starts`, `let_go_modes`).
LET_GO_REST = 0.25


def hidden_mode(m: Motion, column: int, wn: float, zeta: float,
                moving: NDArray[np.bool_] | None = None, let_go: FloatArray | None = None) -> FloatArray:
    """The regressors (N, 2), or (N, 2 + 2·s), of an unread mass that cart `column` pulls
    through a spring: its position, which with this cart held rings at `wn` (rad/s) with damping `zeta`, driven by
    this cart's position (a hand on this cart moves it only through the spring),

        z = G·x_j,  G = wn² / (s² + 2·zeta·wn·s + wn²),

    and its dry friction's share, G·(-sgn ż) (sgn smoothed over a hundredth of ż's range)
    while this cart moves (where it rests, z's leftover linear ringing is not the mass's,
    which friction stops, and its sign would drive G at resonance), both from rest at their
    first values (a record starts with the carts at rest; one that
    starts in motion fits worse, and the free model stays without them). The spring's force
    on this cart is a combination of them. `moving`: `moving_samples` of the cart's velocity,
    when the caller has them. With `let_go` (N,) m, the mass's own motion in z's units as a
    fit has it (zeros before one), that motion is taken into ż's sign, and its free motion
    from wherever it was at each of the s `motion_starts` enters too (`let_go_modes`, from
    half a smoothing window before: the smoothed velocity rises that much early;
    `hand.let_go_refit`)."""
    from scipy.signal import lfilter, lfilter_zi  # deferred: keeps `import ident` fast
    b, a = _oscillator_foh(wn, zeta, m.dt)
    zi = lfilter_zi(b, a)

    def response(u: FloatArray) -> FloatArray:
        return np.asarray(lfilter(b, a, u, zi=zi * u[0])[0], dtype=np.float64)

    z = response(m.x[:, column])
    dz = np.gradient(z if let_go is None else z + let_go, m.dt)
    if moving is None:
        moving = moving_samples(m.v[:, column])
    cols = [z, response(-np.tanh(dz / max(0.01 * float(np.ptp(dz)), 1e-12)) * moving)]
    if let_go is not None:
        for start in motion_starts(m, moving):
            cols += list(let_go_modes(m.n_samples, max(0, start - m.window // 2), wn, zeta, m.dt).T)
    return np.column_stack(cols)


def motion_starts(m: Motion, moving: NDArray[np.bool_]) -> list[int]:
    """The samples where a cart of `moving` (N,) samples begins to move after resting or being
    held (the record's start included) for at least `LET_GO_REST` of a period, and then moves
    for as long (not a reversal's slow samples, nor a stuck cart's creep)."""
    span = m.samples(LET_GO_REST * m.period_s)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(np.int8), [0]])))
    starts, rest_from = [], 0
    for first, stop in edges.reshape(-1, 2):   # [first, stop) of each moving run
        if first - rest_from >= span and stop - first >= span:
            starts.append(int(first))
        rest_from = int(stop)
    return starts


def let_go_modes(n: int, start: int, wn: float, zeta: float, dt: float) -> FloatArray:
    """The regressors (n, 2) of the mass of `hidden_mode` let go at sample `start` from a
    position and velocity the model does not know, while the cart it hangs on rests: zero
    before `start`, then the oscillator's step and impulse responses (zeta < 1, τ = (k -
    start)·dt, wd = wn·√(1 - zeta²)),

        S(τ) = 1 - e^(-zeta·wn·τ)·(cos wd·τ + zeta/√(1 - zeta²)·sin wd·τ),
        I(τ) = e^(-zeta·wn·τ)·sin wd·τ,

    both continuous at `start`. The mass from (z0, v0) towards u is z = z0 - (z0 - u)·S +
    (v0/wd)·I: the constant is the free model's offset, and a held mass's pull, z0 - G·x_j, is
    in the hand's force until the let-go. `G·x_j` from rest took the mass to have followed the
    cart: a hand that holds it at its own rest while it holds the cart off its rest (a hold of
    two carts read through one encoder, let go together) left the first swing misfit by 5-13 %
    of the hold's force, and the release was dated up to 16 samples late (red team
    `two_cart_coulomb_y1` 3702 and 3831)."""
    on = np.arange(n) >= start
    tau = np.maximum(np.arange(n) - start, 0) * dt
    env = np.exp(-zeta * wn * tau) * on
    root = math.sqrt(max(1.0 - zeta * zeta, 1e-12))
    wd = wn * root
    return np.column_stack([on - env * (np.cos(wd * tau) + zeta / root * np.sin(wd * tau)),
                            env * np.sin(wd * tau)])


def _oscillator_foh(wn: float, zeta: float, dt: float) -> tuple[FloatArray, FloatArray]:
    """(b, a) of wn² / (s² + 2·zeta·wn·s + wn²) discretized with a first-order hold over `dt`,
    as `scipy.signal.cont2discrete(..., method="foh")` gives them (to rounding), from one 4×4
    matrix exponential: the search calls it ~100 times a record, and the general routine's
    conversions took three quarters of its time."""
    from scipy.linalg import expm  # deferred: keeps `import ident` fast
    aug = np.zeros((4, 4))
    aug[:2, :2] = np.array([[0.0, 1.0], [-wn * wn, -2.0 * zeta * wn]]) * dt
    aug[1, 2] = wn * wn * dt
    aug[2, 3] = 1.0
    e = expm(aug)
    ad, g1, g2 = e[:2, :2], e[:2, 2], e[:2, 3]
    bd = g1 - g2 + ad @ g2
    den = np.array([1.0, -(ad[0, 0] + ad[1, 1]), ad[0, 0] * ad[1, 1] - ad[0, 1] * ad[1, 0]])
    # C·adj(zI - Ad)·Bd + D·det(zI - Ad), C = (1, 0), D = g2[0]
    num = g2[0] * den + np.array([0.0, bd[0], ad[0, 1] * bd[1] - ad[1, 1] * bd[0]])
    return num, den


def coupling_holds(kappa: float, own: float) -> bool:
    """Whether the hidden mass pulls as a spring can: its position's coefficient `kappa`
    (1/s²) positive and below this cart's `own` stiffness (the coupling spring is part of
    it; κ near it makes z a copy of x_j, a degenerate fit)."""
    return 0.0 < kappa < own


@dataclass(frozen=True)
class MassCandidate:
    """An unread mass's `hidden_mode` `regressors` (N, 2) at its frequency `wn` (rad/s,
    with this cart held) and damping `zeta`."""

    regressors: FloatArray
    wn: float
    zeta: float


def mass_candidates(m: Motion, column: int, base: FloatArray, let_go: bool = False) -> list[MassCandidate]:
    """The `hidden_mode` candidates whose fit beside the free model's leaves the least
    median |residual| over the moving samples (at most `HIDDEN_SEARCH_SAMPLES` of them), by
    a least-squares fit and by a least-trimmed-squares one on the `HIDDEN_KEEP` share it fits
    best (the hand's phase drags the plain fit, and its valley lies elsewhere): per
    fit, its frequency on `HIDDEN_RATIOS` of the ringing's ω below half the Nyquist frequency
    (at the middle damping, every `HIDDEN_COARSE_STEP`-th ratio, then every ratio around the
    best `HIDDEN_VALLEYS` minima), then the damping on `HIDDEN_DAMPING`, then the frequency
    refined between its grid neighbours. `base` (N, p): the free model's regressors of cart
    `column` (`hand.regressors`), its stiffness first. `let_go`: with the mass let go from
    wherever it was at each start of motion (`hidden_mode`'s let-go modes). One or two
    candidates; none on a short record."""
    from scipy.optimize import minimize_scalar  # deferred: keeps `import ident` fast
    moving = moving_samples(m.v[:, column])
    if np.count_nonzero(moving) < HIDDEN_MIN_MOVING:
        return []
    rows = np.flatnonzero(moving)
    rows = rows[::math.ceil(rows.size / HIDDEN_SEARCH_SAMPLES)]
    free = base[rows]
    target = m.a[rows, column]
    still = np.zeros(m.n_samples) if let_go else None
    wn = 2.0 * np.pi / m.period_s
    ratios = [r for r in HIDDEN_RATIOS if r * wn <= 0.5 * np.pi / m.dt]
    if not ratios:
        return []

    @functools.cache
    def spreads(ratio: float, zeta: float) -> tuple[float, float]:
        """(plain, trimmed): median |residual| of each fit (1e300 where the coupling fails:
        finite, as the bounded search needs); each (ratio, damping) fitted once."""
        basis = np.column_stack([free, hidden_mode(m, column, ratio * wn, zeta, moving, still)[rows]])
        keep = np.ones(target.size, dtype=bool)
        out = []
        for _ in range(1 + HIDDEN_TRIMS):
            coef = np.linalg.lstsq(basis[keep], target[keep], rcond=None)[0]
            residual = np.abs(target - basis @ coef)
            median = float(np.median(residual))
            out.append(median if coupling_holds(float(coef[free.shape[1]]), float(coef[0])) else 1e300)
            keep = residual <= np.quantile(residual, HIDDEN_KEEP)
        return out[0], out[-1]

    middle = HIDDEN_DAMPING[len(HIDDEN_DAMPING) // 2]
    costs = np.full((2, len(ratios)), np.inf)
    coarse = range(0, len(ratios), HIDDEN_COARSE_STEP)
    for c in coarse:
        costs[:, c] = spreads(ratios[c], middle)
    # the valley of a lightly damped mass lies between coarse points: look closer around the
    # best few coarse minima of either fit
    for k in range(2):
        minima = [c for c in coarse if costs[k, c] <= min(costs[k, max(0, c - HIDDEN_COARSE_STEP)],
                                                          costs[k, min(len(ratios) - 1, c + HIDDEN_COARSE_STEP)])]
        for c in sorted(minima, key=lambda c: costs[k, c])[:HIDDEN_VALLEYS]:
            for f in range(max(0, c - HIDDEN_COARSE_STEP + 1), min(len(ratios), c + HIDDEN_COARSE_STEP)):
                if not np.isfinite(costs[k, f]):
                    costs[:, f] = spreads(ratios[f], middle)

    def refined(k: int) -> tuple[float, float]:
        """(ratio, damping) of fit `k`'s best grid point, its damping chosen, then refined."""
        i = int(np.argmin(costs[k]))
        zeta = min(HIDDEN_DAMPING, key=lambda z: spreads(ratios[i], z)[k])
        lo, hi = ratios[max(0, i - 1)], ratios[min(len(ratios) - 1, i + 1)]
        best = minimize_scalar(lambda r: spreads(float(r), zeta)[k], bounds=(lo, hi), method="bounded",
                               options={"xatol": 1e-3 * ratios[i]})
        return float(best.x), zeta

    found = dict.fromkeys(refined(k) for k in range(2))
    return [MassCandidate(hidden_mode(m, column, ratio * wn, zeta, moving, still), ratio * wn, zeta)
            for ratio, zeta in found]
