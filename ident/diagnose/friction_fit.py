"""The dry-friction candidate's fit: two stages (large-amplitude part, then every sample)
from several starts, since where a frictional cart stops depends discontinuously on the
parameters. No I/O here."""

from __future__ import annotations

import itertools

import numpy as np

from ident.diagnose.baseline import linear_starts
from ident.diagnose.breakaway import search_ratios
from ident.diagnose.evidence import EvidenceResult
from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem, best_rows, cheapest, ranked_plateaus, ranked_rows
from ident.diagnose.valley import (
    VALLEY,
    other_modes,
    valley_chains,
    valley_walk_rows,
    with_modes,
)
from ident.physics.chain import modes
from ident.simple_start import envelope_friction


def fit_friction(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                 typical: FloatArray, ev: EvidenceResult, max_nfev: int) -> FitResult:
    """Friction fits in two stages, from two starts.

    The linear fit has put the extra loss into viscous damping, and where a frictional cart
    stops depends discontinuously on the parameters; so each start is first fitted on the
    large-amplitude part of the run (until the half-cycle peaks fall below 30 % of the
    first), where the cost is smooth, then on every sample. Starts: the current damping, the
    damping implied by the envelope ratio with friction on a grid, and (one cart driven by a
    force input) ζ and the friction both read off the extrema of a ring (`_extrema_start`).
    Two carts read by both encoders are also fitted, apart, from the chains of the baseline's
    other starts (`_other_chain_starts`), and the better fit kept. Two carts read through one
    encoder are fitted in stages (`_fit_in_stages`), then walked across their valley of chains
    with the same modes, the friction carried (`_walk_valley`).
    """
    n_cut = _large_amplitude_samples(prob, ev)
    candidates = [theta0]
    if prob.carts == 1:
        # the linear fit put the friction's loss into ζ: restart from a lighter damping, the
        # envelope's (a free ringing) or a quarter of the current one, friction on a grid
        zeta_alt = 0.25 * theta0[1]
        if ev.envelope_ratio < 1.0:
            half_period = np.pi / theta0[0]
            zeta_alt = -np.log(max(ev.envelope_ratio, 1e-3)) / half_period / theta0[0]
        alt = theta0.copy()
        alt[1] = float(np.clip(zeta_alt, 1e-4, 0.9 * max(theta0[1], 1e-4)))
        at = spec.block("coulomb_friction").start
        f_max = theta0[0] ** 2 * prob.amplitude
        candidates.append(best_rows(spec, prob, alt, slice(at, at + 1),
                                     [np.array([g * f_max]) for g in (0.003, 0.01, 0.03, 0.1)]))
        # with a force input, also both read off the ring's extrema, as the simple fit starts
        # (a grid a factor 3 apart from the viscous envelope's ζ left a motor pulse's friction
        # 42-57 % off); not for a release, whose starts above suffice (with it, a generated
        # held-cart flick's breakaway ratio landed 5.5 % off)
        ring = None if prob.inputs is None else _extrema_start(prob, prob.inputs, float(theta0[0]))
        if ring is not None:
            row = theta0.copy()
            row[1] = float(np.clip(ring[0], 1e-4, 1.5))
            row[at] = ring[1]
            candidates.append(row)
    else:
        candidates += _two_cart_friction_starts(spec, prob, theta0)
    if prob.carts == 2 and spec.observed < spec.carts:
        staged = _fit_in_stages(spec, prob, candidates, (lower, upper, typical), ev, max_nfev)
        return _walk_valley(spec, prob, staged, (lower, upper, typical), ev, max_nfev)
    short = spec.cut(n_cut)
    firsts = [fit(short, start, lower, upper, typical, prob.dt, prob.y[:n_cut], prob.train[:n_cut],
                  max_nfev=2 * max_nfev) for start in candidates]
    # every start through the smooth large-amplitude stage; those that then fit the whole
    # window best (where the carts stick tells the starts apart: one batch) go on to every sample
    rows = np.array([f.theta for f in firsts])
    on_all = cheapest(spec, prob, list(rows), FULL_FITS)
    best: FitResult | None = None
    for start in on_all:
        result = fit(spec, start, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    others = _other_chain_starts(spec, prob, theta0) if prob.carts == 2 else []
    if others:
        # apart, on a window that grows in stages: ranked among the current chain's starts they
        # displaced ones that fitted better in the end, and one jump from the large-amplitude
        # part to every sample left a fast mode's friction in a local minimum
        other = _fit_in_stages(spec, prob, others, (lower, upper, typical), ev, max_nfev)
        best = other if other.sse_train < best.sse_train else best
    return best


#: A one-encoder chain's friction fit in stages: (peak level the window runs to, starts fitted
#: there); every start on the first, the best of each stage on to the next, the best on every sample.
STAGES = ((0.3, None), (0.1, 4), (0.0, 2))


def _fit_in_stages(spec: ModelSpec, prob: Problem, starts: list[FloatArray],
                   bounds: tuple[FloatArray, FloatArray, FloatArray], ev: EvidenceResult,
                   max_nfev: int) -> FitResult:
    """Two carts through one encoder: each start fitted on a window that grows in `STAGES`,
    ranked by its fit there. Where each cart sticks moves the cost by steps, more so the longer
    the window, and the starts lie across a valley of near-equal linear fits: one jump from the
    large-amplitude part to every sample ranked them by chance (on 70 generated cases 57 had
    both frictions within 5 %; in stages 63, the fit as close to the noise floor)."""
    lower, upper, typical = bounds
    n = prob.y.shape[0]
    rows, results = starts, []
    for level, count in STAGES:
        cut = _large_amplitude_samples(prob, ev, level) if level > 0.0 else n
        part = spec.cut(cut) if cut < n else spec
        results = sorted((fit(part, row, lower, upper, typical, prob.dt, prob.y[:cut], prob.train[:cut],
                              max_nfev=max_nfev if cut == n else 2 * max_nfev)
                          for row in rows[:count]), key=lambda r: r.sse_train)
        rows = [r.theta for r in results]
    return results[0]


def _walk_valley(spec: ModelSpec, prob: Problem, best: FitResult,
                 bounds: tuple[FloatArray, FloatArray, FloatArray], ev: EvidenceResult,
                 max_nfev: int) -> FitResult:
    """Two carts through one encoder: the staged fit `best` moved across the one-encoder family
    (`valley_chains`, its modes kept) to every `WALK_LOGITS` share and a few `WALK_STEPS` about
    its own, each move carrying its friction (cart 1's F1 as fitted, cart 2's F2 with F2 / b2,
    what cart 1's encoder fixes of it, `identifiable`, kept), all fitted again in stages; the
    cheaper of that and `best` returned.

    The valley's basins are narrow and where each cart sticks separates them: started from the
    grids' friction levels, the staged fit ended in the wrong one (generated seed 1587633242:
    its chain 29 % along the valley where the truth is at 9 %, at 9 times the cost the truth's
    basin has; seed 1868035653: 60 % for 56 %, 5 times). With the fitted friction carried, the
    starts land in the basin near them. On 100 generated runs (bench seeds 53-55) the friction
    fit's cost came within 2 % of the fit started from the true chain in 89 before, 99 after (the
    last at 6 %, 9.0 % along the valley for the truth's 9.2 %). Both frictions within 5 % in the
    final reports (`tools/bench_diagnose.py --one-encoder N`): seed 53 18 -> 20 of 20, 54 36 -> 37,
    55 31 -> 33, unseen 56 37 -> 38 and 57 38 -> 39 of 40, for about 0.3 s more per run."""
    rows = valley_walk_rows(spec, best.theta)
    if not rows:
        return best
    walked = _fit_in_stages(spec, prob, rows, bounds, ev, max_nfev)
    return walked if walked.sse_train < best.sse_train else best


#: How two carts' friction levels are shared in the starts' grids: cart 1, cart 2, both, and
#: 1 : 0.3 either way (the current chain read by both encoders takes the first three).
FRICTION_SHARES = tuple(np.array(p) for p in ((1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.3), (0.3, 1.0)))

#: Starts fitted on to every sample (the best after the large-amplitude stage).
FULL_FITS = 2


def _two_cart_friction_starts(spec: ModelSpec, prob: Problem, theta0: FloatArray) -> list[FloatArray]:
    """Two carts: the linear fit put both frictions' loss into c1/m1 and c2/m2, and which cart
    rubs shows only in how each mode's envelope decays. Restart from a quarter of that damping
    with the friction on cart 1 only, cart 2 only or both, on a grid of levels (each chain's
    best row).

    Through one encoder the linear chain is not identifiable: x1 (with cart 2's start free)
    sees only the characteristic polynomial, whose four coefficients g1 + g2, A + D + g1 g2,
    g1 D + g2 A and A D - b1 b2 leave a one-parameter family of (A, D, g1, g2) (A = a1 + b1,
    D = b2 + a2, notation of `ident.physics.chain`); with light damping A runs between the two
    modes' wn² and D = trace - A. Friction breaks the tie (where a cart sticks depends on its
    own stiffness), but the linear fit lands anywhere in the family, and friction on the wrong
    cart then fits best. So the chain is also started across that family (`VALLEY`), each with
    cart 2's start as fitted or at rest (whichever row fits better), and with its modes moved
    (`other_modes`)."""
    at = spec.block("coulomb_friction").start
    chain = theta0.copy()
    chain[4:6] = 0.25 * theta0[4:6]
    f_max = float(np.max(theta0[:4])) * prob.amplitude
    levels = [g * f_max * p for p in FRICTION_SHARES[:3] for g in (0.003, 0.01, 0.03, 0.1)]
    out = [best_rows(spec, prob, chain, slice(at, at + 2), levels)]
    if spec.observed == spec.carts:
        return out
    # through one encoder the valley is rugged: where each cart sticks decides, so finer levels
    # and unequal shares (factor 2 apart, 0.3-2 between the carts)
    levels = [g * f_max * p for p in FRICTION_SHARES for g in (0.003, 0.006, 0.012, 0.025, 0.05, 0.1)]
    out += [best_rows(spec, prob, chain, slice(0, chain.size), _with_levels(spec, levels, [pair]))
            for pair in valley_chains(chain, spec)]
    # (half the levels and every other valley share: each start is a batch of simulations)
    return out + _other_mode_starts(spec, prob, chain, levels[1::2])


def _with_levels(spec: ModelSpec, levels: list[FloatArray], pairs: list[tuple[FloatArray, FloatArray]]
                ) -> list[FloatArray]:
    """Each chain of `pairs` with each friction level."""
    at = spec.block("coulomb_friction").start
    rows = []
    for c in (c for pair in pairs for c in pair):
        for level in levels:
            row = c.copy()
            row[at:at + 2] = level
            rows.append(row)
    return rows


def _other_mode_starts(spec: ModelSpec, prob: Problem, chain: FloatArray, levels: list[FloatArray]
                       ) -> list[FloatArray]:
    """A one-encoder chain's friction starts with one of its modes kept and the other moved
    (`other_modes`): the best row of each across every other valley share and the friction
    `levels`."""
    return [best_rows(spec, prob, chain, slice(0, chain.size),
                      _with_levels(spec, levels, valley_chains(with_modes(chain, kept, other), spec, VALLEY[::2])))
            for kept, other in other_modes(chain)]


def _other_chain_starts(spec: ModelSpec, prob: Problem, theta0: FloatArray) -> list[FloatArray]:
    """Friction starts (two carts read by both encoders) in the chains of the linear baseline's
    other starts (`baseline.linear_starts`: the position's and the velocity's spectral peaks)
    whose modes differ from the current chain's by more than 20 %, damping a quarter of theirs,
    each with the best of 30 friction levels (cart 1, cart 2, both, 1 : 0.3 either way; 0.3-10 %
    of the lower mode's pull at the swing: the stiffest spring's overstates a light cart's).

    Without friction a linear chain imitates dry friction's straight decay by a beat of two
    close modes and leaves a fast second mode (a light cart on a stiff spring, its ring stopped
    by friction within a few cycles) unmodelled: the best linear fit, from which friction then
    started in the wrong chain (red team two_cart_coulomb_y12 seed 1010: modes 11.8 and 12.8
    rad/s for a true 12.0 and 41.8, a 6.6 Hz 'coupled mode' taken, fit 6 points under the
    noise floor, cart 2's friction 95 % off)."""
    if prob.inputs is not None or prob.y.shape[1] != 2:
        return []
    at = spec.block("coulomb_friction").start
    own = np.sort([w for w, _ in modes(theta0[None, :6], 2)])
    out = []
    for start in linear_starts(prob):
        other = np.sort([w for w, _ in modes(start[None, :6], 2)])
        if np.all(np.isfinite(start)) and np.any(np.abs(other / own - 1.0) > 0.2):
            row = theta0.copy()
            row[:start.size] = start
            row[4:6] = 0.25 * start[4:6]
            f_low = float(other[0]) ** 2 * prob.amplitude
            levels = [g * f_low * p for p in FRICTION_SHARES for g in (0.003, 0.01, 0.03, 0.1)]
            out.append(best_rows(spec, prob, row, slice(at, at + 2), levels))
    return out


#: Breakaway levels (in kinetic levels) a static friction's fit starts from.
STATIC_GRID = (1.02, 1.05, 1.1, 1.15, 1.2, 1.3, 1.4, 1.5, 1.7, 2.0, 2.5)
#: Relative steps of each cart's breakaway ratio tried around the fitted one.
STATIC_STEPS = (0.9, 0.94, 0.97, 1.03, 1.06, 1.1)


def static_rows(carts: int) -> list[FloatArray]:
    """Breakaway ratios to start from: `STATIC_GRID` on every cart and, with two carts, on one
    cart with the other's breakaway at its kinetic level (each cart rubs on its own surface)."""
    rows = [np.full(carts, r) for r in STATIC_GRID]
    if carts == 2:
        rows += [np.array([r, 1.0]) for r in STATIC_GRID] + [np.array([1.0, r]) for r in STATIC_GRID]
    return rows


def fit_static_friction(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                        typical: FloatArray, ev: EvidenceResult, max_nfev: int) -> FitResult:
    """The breakaway ratios r_i (static over kinetic friction) with the rest of the model.

    Where a cart sticks moves discontinuously with r: a least-squares step sees no gradient in
    r (a finite difference moves no stick decision) and leaves it where it started, while the
    other parameters (the held cart's coupling, the friction level) bend to make up for a wrong
    one (generated held-cart runs: r stuck at the grid's 1.4 for a true 1.50, the coupling 5.8 %
    off). So: a grid of ratios (`static_rows`), then each cart's ratio stepped by `STATIC_STEPS`
    around the fit (one batch) and, if a step fits better, fitted again from there.

    The grid is tried on two models: the current one, and (one cart) the current one with ζ
    and the kinetic friction read off the ring's extrema (`envelope_friction`: the decay from
    one extreme to the next while the cart slides, which the breakaway level does not touch). A
    model with one friction level sets it between the kinetic and the breakaway level (it must
    decay the swings and stop the cart where it stuck) and its damping makes up for the
    difference, a valley in which the grid's ratios alone found no way down (generated
    viscous + Coulomb, static 1.46 x kinetic: ratio 1.05, kinetic 7.9 % and ζ 8.1 % off at 4
    times the true model's misfit). The best two grid rows of the current model and the best
    of the ring's are fitted. Two carts through one encoder have no ring to read each cart's
    kinetic level off, and the grid's rows ranked unfitted told nothing of where they fit to:
    every diagonal row (both ratios r) is fitted with its kinetic levels lowered by 2 / (1 + r)
    (`_lowered_kinetic_rows`; generated wide-cart seed 2053547375, breakaway 1.22 and 1.48 times
    kinetic: no breakaway had been found, 1.08 points under the noise floor). When the best of
    those still misses by more than the noise (`_misfit_left`), each of a few ratios is also fitted
    in stages from steps along the valley of chains (`_walked_ratio_fits`): the kinetic-only
    chain's basin has none that gains.

    Where a stuck cart breaks away again (a held cart's wander pulls it) also moves with the
    other parameters, and a model without a breakaway has bent them to stop the cart where it
    stuck: the held cart's coupling β most (generated Coulomb + held cart, breakaway 1.15 x
    kinetic: β 77 s⁻² for a true 168). Ranked at those values the grid's smallest ratios came
    first, and from them the fit ended with β 45 % off (at 4.3e-6 m² where the truth's basin
    has 3.9e-7). So one cart also fits the current model where it rings freely (the peaks down
    to 30 % of the first, `_large_amplitude_samples`), which the breakaway hardly touches, and
    ranks the grid from that fit; and with β in the model every grid row and every step is
    fitted. On 40 generated Coulomb + held-cart runs (seed 45) β and the friction within 5 %:
    31 -> 38.

    With β in the model the cost moves with r also between stick decisions (where the held
    cart's pull breaks a stuck cart away), but the steps above are free fits, which a finite
    difference in r can send anywhere: where they ended depended on the CPU's rounding (bench
    seed 12, case 39, breakaway 1.417 x kinetic: r within 5 % of it on CI's machine, 1.339 on
    an AMD EPYC, β 3.4 % and the friction 1.6 % off there). So each ratio is then searched between the grid's
    neighbouring levels by golden section over the profile cost, the other parameters refitted
    at each trial ratio (`breakaway.search_ratios`; there 1.402, β 0.01 % and the friction
    0.25 % off).
    """
    block = spec.block("static_friction")
    rows = static_rows(prob.carts)
    # with a held cart's coupling in the model every row is fitted (above)
    starts = (ranked_rows(spec, prob, theta0, block, rows, len(rows)) if "held_cart_motion" in spec.effects
              else ranked_plateaus(spec, prob, theta0, block, rows, 2))
    if prob.carts == 1:
        # the model refitted where the cart rings freely, the ratios ranked from there
        cut = _large_amplitude_samples(prob, ev)
        free_fit = fit(spec.cut(cut), theta0, lower, upper, typical, prob.dt, prob.y[:cut], prob.train[:cut],
                       max_nfev=2 * max_nfev)
        starts += ranked_plateaus(spec, prob, free_fit.theta, block, rows, 2)
    ring = None if prob.carts != 1 else envelope_friction(prob.tau, prob.y[:, 0], float(prob.tau[0]) - 1.0,
                                                          float(theta0[0]))
    if ring is not None:
        row = theta0.copy()
        for at, value in ((spec.names.index("zeta"), ring[0]), (spec.block("coulomb_friction").start, ring[1])):
            row[at] = float(np.clip(value, lower[at], upper[at]))
        starts += ranked_plateaus(spec, prob, row, block, rows, 1)
    one_encoder = prob.carts == 2 and spec.observed < spec.carts
    if one_encoder:
        starts += _lowered_kinetic_rows(spec, theta0)
    fits = [fit(spec, row, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
            for row in starts]
    if one_encoder and _misfit_left(fits, prob, ev):
        fits += _walked_ratio_fits(spec, prob, theta0, (lower, upper, typical), ev, max_nfev)
    best = min(fits, key=lambda r: r.sse_train)
    ratios = best.theta[block]
    steps = []
    for i in range(ratios.size):
        for k in STATIC_STEPS:
            row = ratios.copy()
            row[i] = max(1.0, ratios[i] * k)
            steps.append(row)
    if "held_cart_motion" in spec.effects:   # every step fitted, as every grid row (above)
        tried = [fit(spec, row, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
                 for row in ranked_rows(spec, prob, best.theta, block, steps, len(steps))]
        stepped = min([best, *tried], key=lambda r: r.sse_train)
        return search_ratios(spec, prob, stepped, (lower, upper, typical), (1.0, *STATIC_GRID), max_nfev)
    moved = ranked_rows(spec, prob, best.theta, block, [ratios, *steps], 1)[0]
    if np.array_equal(moved[block], ratios):
        return best
    again = fit(spec, moved, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
    return again if again.sse_train < best.sse_train else best


#: Breakaway ratios (both carts) a one-encoder chain's static friction is walked from
#: (`_walked_ratio_fits`): a breakaway of 1.1-1.7 times the kinetic level.
WALKED_RATIOS = (1.1, 1.2, 1.3, 1.4, 1.5, 1.7)
#: The misfit (in the noise's SSE) above which a one-encoder chain's breakaway is searched for
#: across the valley (`_misfit_left`).
MISFIT_LEFT = 2.0


def _misfit_left(fits: list[FitResult], prob: Problem, ev: EvidenceResult) -> bool:
    """Whether the best of `fits` still misses by more than `MISFIT_LEFT` times the noise's SSE
    (n σ², σ the evidence's noise estimate): only then is there a breakaway left to look for."""
    n = int(np.count_nonzero(prob.train)) * prob.y.shape[1]
    return min(f.sse_train for f in fits) > MISFIT_LEFT * n * ev.noise_std_m ** 2


def _walked_ratio_fits(spec: ModelSpec, prob: Problem, theta0: FloatArray,
                       bounds: tuple[FloatArray, FloatArray, FloatArray], ev: EvidenceResult,
                       max_nfev: int) -> list[FitResult]:
    """Two carts through one encoder: for each `WALKED_RATIOS` breakaway ratio (both carts,
    kinetic levels lowered by 2 / (1 + r) as in `_lowered_kinetic_rows`), the chain fitted in
    stages (`_fit_in_stages`) from itself and from the `WALK_STEPS` about its share of the
    one-encoder valley (`valley_walk_rows`), one staged fit per ratio.

    A model with one friction level has moved the whole chain to stop the carts where they
    stuck: the kinetic levels, the dampings and where it sits in the valley of chains with the
    same modes. A breakaway ratio started from there, fitted directly on every sample, finds no
    way down (the ratio moves no stick decision a finite difference sees, and the chain's basin
    is narrow): generated seed 1359388729, breakaway 1.38 and 1.39 times kinetic, every grid
    row ended at 1.02 with the misfit 14 times the noise floor, where the staged fit from a
    step along the valley at r = 1.5 reaches it. Ranked together on the large-amplitude stage
    the ratios cannot be told apart (the carts hardly stick there), so each ratio is staged on
    its own and the fits compared on every sample."""
    block, kinetic = spec.block("static_friction"), spec.block("coulomb_friction")
    out = []
    for ratio in WALKED_RATIOS:
        row = theta0.copy()
        row[block] = ratio
        row[kinetic] = theta0[kinetic] * 2.0 / (1.0 + ratio)
        out.append(_fit_in_stages(spec, prob, [row, *valley_walk_rows(spec, row, ())], bounds, ev, max_nfev))
    return out


def _lowered_kinetic_rows(spec: ModelSpec, theta0: FloatArray) -> list[FloatArray]:
    """Both carts' breakaway ratios at each `STATIC_GRID` value with each kinetic level lowered
    by 2 / (1 + r), the breakaway and kinetic levels' mean where the one level was."""
    block, kinetic = spec.block("static_friction"), spec.block("coulomb_friction")
    rows = []
    for ratios in (np.full(2, r) for r in STATIC_GRID):
        row = theta0.copy()
        row[block] = ratios
        row[kinetic] = theta0[kinetic] * 2.0 / (1.0 + ratios)
        rows.append(row)
    return rows


def _extrema_start(prob: Problem, inputs: FloatArray, wn: float) -> tuple[float, float] | None:
    """(ζ, f) of one cart read off the extrema of its widest ring (`envelope_friction`): the
    window split where the force `inputs` (N, m) change (a motor pulse rings about a new level
    after each edge), the stretch of the largest swing taken. None with fewer than four extrema."""
    y = prob.y[:, 0]
    changes = np.flatnonzero(np.any(np.diff(inputs.reshape(y.size, -1), axis=0) != 0.0, axis=1)) + 1
    edges = [0, *changes.tolist(), y.size]
    stretches = [(a, b) for a, b in itertools.pairwise(edges) if b - a >= 8]
    if not stretches:
        return None
    a, b = max(stretches, key=lambda ab: float(np.ptp(y[ab[0]:ab[1]])))
    return envelope_friction(prob.tau[a:b], y[a:b], float(prob.tau[a]) - 1.0, wn)


def _large_amplitude_samples(prob: Problem, ev: EvidenceResult, level: float = 0.3) -> int:
    """Work samples up to a quarter period after the last peak above `level` of the first."""
    amps = ev.extrema[:, 1]
    n = prob.tau.size
    if amps.size < 4:
        return n
    last = float(ev.extrema[np.flatnonzero(amps >= level * amps[0])[-1], 0])
    quarter = 0.25 * (ev.extrema[-1, 0] - ev.extrema[0, 0]) / max(amps.size - 1, 1) * 2
    return int(min(n, max(np.searchsorted(prob.tau, last + quarter), 40)))


__all__ = ["STATIC_GRID", "fit_friction", "fit_static_friction", "static_rows"]
