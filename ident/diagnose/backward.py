"""Backward elimination after the forward selection: drop an earlier effect the final model no
longer needs.

Forward selection judges each effect against the model it extends. An effect taken early may
only have stood in for one taken later (a softening cubic spring bending the frequency of the
small late cycles, which pre-sliding friction's stiffness at small amplitude then explains):
the final model with it is then no better than the final model without it. Each effect of the
carts accepted before the last is judged again, as `select.judge` judges an extension, but now
as the final model against the final model without it, refitted and cross-validated
(`without(trial, final, 2)`):

    LR_cv = n ln(CV_without / CV_final) > χ²_p(1 - ALPHA) (+ look-elsewhere), the same on the
    whole window, and the BIC drop > 0 (under an encoder lattice, see `_weakest`).

Of those that fail, the weakest (least LR_cv) is dropped and the pass is repeated on the
smaller model, until every earlier effect passes (at most one pass per accepted effect); a
last step whose drops leave the model worse than before it is undone (`settle`). An
encoder lattice is the sensor's and is not judged again, nor is an effect another one refines
(Coulomb friction under static or pre-sliding friction: `REQUIRES`). No I/O here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from ident.diagnose.candidates import Trial
from ident.diagnose.fitting import FitResult
from ident.diagnose.select import Judgement, Step, judge

#: `without(trial, result, refit)`: `result` with `trial.effect` taken out, evaluated (0),
#: refitted (1), refitted and cross-validated (2) within the trial's bounds.
Without = Callable[[Trial, FitResult, int], FitResult]


@dataclasses.dataclass(frozen=True)
class Elimination:
    """The steps that remain (the last one's model the refitted final model) and, in the order
    they were dropped, the judgements of the dropped effects (the final model against the final
    model without the effect: `passes` is False), and the last trial with the bounds of the
    final model's parameters (those of the dropped effects taken out)."""

    steps: list[Step]
    dropped: list[Judgement]
    last: Trial


def eliminate(steps: list[Step], last: Trial, without: Without, carts: int) -> Elimination:
    """Drop, one at a time, the weakest earlier effect the final model does not need.

    `last` is the trial of the last accepted effect: its bounds cover every parameter of the
    final model, and the refit without an effect keeps those of the others. A model that reads
    through an encoder lattice was cross-validated as the lattice's readings of the carts'
    held-out predictions (`candidates.refine`), which is no cost of the kind its refit without
    an effect has (red team coupled_light seed 200: the 6.9 Hz mode's whole-window ratio 262
    against a bound of 29, its held-out ratio -88 from the mismatch alone): see `_weakest`."""
    dropped: list[Judgement] = []
    baseline = steps[0].before
    first = len(steps)   # the first step whose forward models held a dropped effect
    for _ in range(len(steps)):
        weakest = _weakest(steps, last, without, carts)
        if weakest is None:
            break
        at, judgement, reduced = weakest
        last = _bounds_without(last, steps[-1].judgement.result, judgement.effect)
        steps = _drop(steps, at, reduced)
        first = min(first, at)
        dropped.append(judgement)
    if dropped:
        steps = _rechained(steps, first, baseline, last, without)
    return Elimination(steps, dropped, last)


def _rechained(steps: list[Step], first: int, baseline: FitResult, last: Trial, without: Without) -> list[Step]:
    """`steps` from `first` on credited along one nested chain without the dropped effects.

    The steps after a dropped one kept their forward models, which held the dropped effect:
    each was credited within a model that is no longer the diagnosis's, and the credits no
    longer added up to the final model's gain (the 2023 open-loop `test_3_13`: a 5-point mode
    dropped, pre-sliding friction, the last step, credited -0.99 points against a model with
    the mode; the four credits summed to 1.8 of the 6.9 points gained). Now the final model is
    peeled from its last effect back to step `first`, each model refitted without the effect
    (`without(..., 1)`), and every step is credited from the model below it. Step `first` is
    credited from the unchanged model below it (`baseline`, the linear one, at step 0), or from
    its own peel when that fits better: as the forward selection credits an effect whose
    refit moved the model to a better optimum (red team `two_cart_coulomb_y12` 1010: a cubic of
    -26 /m²s², 0.008 points over its model without it, was credited +3.16 points from the
    dropped steps' model before)."""
    out = list(steps)
    model = steps[-1].judgement.result
    for k in range(len(steps) - 1, first - 1, -1):
        judgement = dataclasses.replace(steps[k].judgement, result=model)
        below = steps[k - 1].judgement.result if k > 0 else baseline
        bare = without(dataclasses.replace(last, effect=judgement.effect), model, 1)
        before = below if k == first and below.sse_train <= bare.sse_train else bare
        out[k] = Step(judgement, before)
        last = _bounds_without(last, model, judgement.effect)
        model = bare
    return out


def _weakest(steps: list[Step], last: Trial, without: Without, carts: int) -> tuple[int, Judgement, FitResult] | None:
    """(step index, judgement, final model refitted without it) of the earlier effect of least
    held-out ratio among those the final model does not need; None when all are needed.

    With an encoder lattice in the final model an effect is judged twice: on the whole window
    read through the lattice (the lattice may explain what it fitted: a spurious mode on a
    coarse lattice, ratio 24 against a bound of 29 once the lattice reads the prediction), and
    held out on the carts' model without the lattice, as the forward selection judged it (the
    lattice is added once the carts' effects are in, `select._yield`): held-out refits through
    the lattice's nearly hard staircase have finite-difference slopes that say nothing and
    compared two arbitrarily converged dynamics (red team coupled_pinned 700: a 5.7 Hz mode at
    +1.05 points, whole-window ratio 187 against 29 through the lattice, held out -41, had been
    dropped). It goes when the whole window read through the lattice does without it; failing
    held out alone does not drop it: the carts' model without the lattice is itself fitted to
    the lattice's staircase, and its held-out refits of a dry-friction model stick elsewhere
    (red team coulomb+held_cart 2202, 69 Hz, 0.35 mm lattice: static friction at a
    whole-window ratio of 732 and held out -75 was dropped, the model read through the lattice
    without it cost 155 times the final model's, and `settle` then undid the held cart's
    coupling that had come after it)."""
    final = steps[-1].judgement.result
    candidates = [s for s in steps[:-1] if _removable(s.judgement.effect, final.spec.effects)]
    if not candidates:
        return None
    read = "quantization" in final.spec.effects
    plain = dataclasses.replace(final, likelihood_gain=None, level_gain=None)
    smooth, smooth_bounds = plain, last
    if read:
        smooth = without(dataclasses.replace(last, effect="quantization"), final, 2)
        smooth_bounds = _bounds_without(last, final, "quantization")
    worst: tuple[int, Judgement, FitResult] | None = None
    for at, step in enumerate(steps[:-1]):
        effect = step.judgement.effect
        if not _removable(effect, final.spec.effects):
            continue
        reduced = without(dataclasses.replace(smooth_bounds, effect=effect), smooth, 2)
        judgement = judge(effect, reduced, smooth, carts)
        if read:   # and through the lattice, on the whole window (not cross-validated)
            through = judge(effect, without(dataclasses.replace(last, effect=effect), final, 1), plain, carts)
            through = dataclasses.replace(through, lr_cv=through.lr_fit)
            if judgement.passes:
                judgement = through
            elif through.passes:   # failing held out alone: kept (see above)
                continue
        if not judgement.passes and (worst is None or judgement.lr_cv < worst[1].lr_cv):
            worst = at, judgement, reduced
    if worst is not None and read:   # the final model without it, read through the lattice
        at, judgement, _ = worst
        worst = at, judgement, without(dataclasses.replace(last, effect=judgement.effect), final, 2)
    return worst


def settle(steps: list[Step], last: Trial, without: Without, carts: int) -> Elimination:
    """`eliminate`, unless its model fits the whole window worse than the forward selection's
    model before its last step: that step is then undone (it gained nothing once what it made
    redundant was dropped) and the steps before it eliminated again.

    Each drop is judged against the model left by the drops before it, so their losses add
    up: on the real 2025 record 07-Feb-2025_11_29_09 (release 1), with its time base
    rounded one way pre-sliding friction came in fourth (+13.8 on a bound of 10.8), then the
    held cart's coupling and the cubic spring went, each held out within the noise of the
    model without the other, and the diagnosis ended at 96.95 % where the three effects before
    pre-sliding had reached 97.62 %."""
    while True:
        elimination = eliminate(steps, last, without, carts)
        before = steps[-1].before
        if not elimination.dropped or elimination.steps[-1].judgement.result.sse_train <= before.sse_train:
            return elimination
        last = _bounds_without(last, steps[-1].judgement.result, steps[-1].judgement.effect)
        steps = steps[:-1]
        if len(steps) < 2:
            return Elimination(steps, [], last)


#: Effects that refine another and cannot stand without it (`candidates.available`).
REQUIRES = {"presliding": "coulomb_friction", "static_friction": "coulomb_friction"}


def _removable(effect: str, effects: tuple[str, ...]) -> bool:
    """Whether `effect` may be judged for dropping: an effect of the carts that no other effect
    of the model refines (a breakaway level is a multiple of the Coulomb level)."""
    return effect != "quantization" and not any(REQUIRES.get(e) == effect for e in effects)


def _bounds_without(last: Trial, final: FitResult, effect: str) -> Trial:
    """`last` with the bounds of `effect`'s parameters in `final` taken out (the smaller final
    model's bounds)."""
    keep = np.ones(final.theta.size, dtype=bool)
    keep[final.spec.block(effect)] = False
    return dataclasses.replace(last, lower=last.lower[keep], upper=last.upper[keep], typical=last.typical[keep])


def _drop(steps: list[Step], at: int, reduced: FitResult) -> list[Step]:
    """`steps` without step `at`, the last one's model the refitted `reduced` (the steps'
    credits are made consistent once every drop is done: `_rechained`)."""
    kept = steps[:at] + steps[at + 1:]
    kept[-1] = Step(dataclasses.replace(kept[-1].judgement, result=reduced), kept[-1].before)
    return kept


__all__ = ["Elimination", "eliminate", "settle"]
