"""Backward elimination: an earlier effect the final model no longer needs is dropped.

Judged as the forward selection judges an extension (`select.judge`): the final model against
the final model refitted without the effect, on the whole window and held out, with the same
bound and the BIC. The costs here are given (the logic under test is the decision, not a fit):
N = 500 residuals, one cart; an effect of 1 parameter needs n ln(SSE ratio) > χ²₁(0.999) =
10.83, a 2 % cut in cost (n ln(1/0.98) = 10.1 fails, 3 % = 15.2 passes).
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose.backward import eliminate
from ident.diagnose.candidates import Trial
from ident.diagnose.fitting import FitResult
from ident.diagnose.models import ModelSpec
from ident.diagnose.select import Judgement, Step, judge

N = 500


def _result(spec: ModelSpec, sse: float, sse_val: float | None = None, tag: float = 0.0) -> FitResult:
    theta = np.full(len(spec.names), tag)
    return FitResult(spec, theta, np.zeros_like(theta), np.zeros((N, 1)), sse, sse if sse_val is None else sse_val,
                     N, len(spec.names))


def _chain(effects: list[str], sse: list[float]) -> list[Step]:
    """Forward steps adding `effects` in order, the model after step k costing sse[k + 1]."""
    spec = ModelSpec((), 1)
    before = _result(spec, sse[0])
    steps = []
    for effect, cost in zip(effects, sse[1:]):
        spec = spec.with_effect(effect)
        after = _result(spec, cost)
        steps.append(Step(judge(effect, before, after, 1), before))
        before = after
    return steps


def _trial(spec: ModelSpec, effect: str) -> Trial:
    p = len(spec.names)
    return Trial(effect, _result(spec, 1.0), np.full(p, -np.inf), np.full(p, np.inf), np.ones(p))


def _without(costs: dict[str, float], calls: list[tuple[str, int]]):
    """`without` giving the final model without each effect the cost `costs[effect]` once
    refitted (2), and 1.5 times the model's own cost merely evaluated (0)."""
    def without(trial: Trial, result: FitResult, refit: int) -> FitResult:
        # a refit is within the model's own bounds: one per parameter of `result`
        assert not refit or trial.lower.size == trial.upper.size == trial.typical.size == result.theta.size
        calls.append((trial.effect, refit))
        bare = ModelSpec(tuple(e for e in result.spec.effects if e != trial.effect), 1)
        cost = costs[trial.effect] if refit else 1.5 * result.sse_train
        return _result(bare, cost)   # parameters 0: a lattice of quantum 0 puts no reading floor
    return without


def _no_revalidation(trial: Trial, result: FitResult) -> FitResult:
    raise AssertionError("no lattice in the model: its own held-out cost compares")


def test_an_early_effect_the_final_model_does_not_need_is_dropped_and_the_rest_kept() -> None:
    # drag first (1.0 -> 0.7), then friction (0.7 -> 0.5); the final model refitted without the
    # drag costs 0.505 (1 %: the friction explains what the drag stood in for), without the
    # friction 0.7 (needed)
    steps = _chain(["quadratic_drag", "coulomb_friction"], [1.0, 0.7, 0.5])
    calls: list[tuple[str, int]] = []
    last = _trial(steps[-1].judgement.result.spec, "coulomb_friction")
    out = eliminate(steps, last, _without({"quadratic_drag": 0.505, "coulomb_friction": 0.7}, calls),
                    _no_revalidation, 1)
    assert [s.judgement.effect for s in out.steps] == ["coulomb_friction"]
    assert [j.effect for j in out.dropped] == ["quadratic_drag"] and not out.dropped[0].passes
    final = out.steps[-1].judgement.result
    assert "quadratic_drag" not in final.spec.effects and final.sse_train == pytest.approx(0.505)
    # the friction step, now right after the model the drag was added to, is credited against
    # that model (the refitted final model lacks the drag, as that model does: a gain of
    # 1.0 -> 0.505, not 0.7 -> 0.505 with the drag's share charged to it)
    assert out.steps[0].before is steps[0].before
    # the last effect is not judged again; the dropped one is refitted and cross-validated
    assert ("quadratic_drag", 2) in calls and ("coulomb_friction", 2) not in calls


def test_effects_the_final_model_needs_are_all_kept() -> None:
    steps = _chain(["quadratic_drag", "coulomb_friction"], [1.0, 0.7, 0.5])
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "coulomb_friction"),
                    _without({"quadratic_drag": 0.6, "coulomb_friction": 0.7}, []), _no_revalidation, 1)
    assert [s.judgement.effect for s in out.steps] == ["quadratic_drag", "coulomb_friction"]
    assert out.dropped == [] and out.steps == steps


def test_of_two_unneeded_effects_the_weaker_goes_first_and_the_other_is_judged_again() -> None:
    # drag and cubic both stand in for the friction; without the drag the cost rises 0.4 %,
    # without the cubic 1.2 %: the drag (weaker) is dropped; then the cubic, judged again on
    # the smaller model (the same stub costs), is dropped too
    steps = _chain(["quadratic_drag", "cubic_stiffness", "coulomb_friction"], [1.0, 0.8, 0.7, 0.5])
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "coulomb_friction"),
                    _without({"quadratic_drag": 0.502, "cubic_stiffness": 0.506, "coulomb_friction": 0.7}, []),
                    _no_revalidation, 1)
    assert [j.effect for j in out.dropped] == ["quadratic_drag", "cubic_stiffness"]
    assert [s.judgement.effect for s in out.steps] == ["coulomb_friction"]


def test_a_model_read_through_a_lattice_is_revalidated_before_the_comparison() -> None:
    # mode, then an encoder lattice whose held-out cost is the lattice's reading of the carts'
    # held-out predictions (here 3x its whole-window cost): against a refit without the mode,
    # cross-validated the ordinary way (0.6), the mode would look useless held out. The final
    # model is cross-validated alike first (0.45), and the mode (0.45 -> 0.6) is kept.
    spec = ModelSpec((), 1)
    linear = _result(spec, 1.0)
    mode = _result(spec.with_effect("coupled_mode"), 0.6)
    lattice_spec = spec.with_effect("coupled_mode").with_effect("quantization")
    read = _result(lattice_spec, 0.45, sse_val=1.35)
    steps = [Step(judge("coupled_mode", linear, mode, 1), linear),
             Step(Judgement("quantization", read, 200.0, 150.0, 27.0, 190.0), mode)]
    revalidated: list[FitResult] = []

    def revalidate(trial: Trial, result: FitResult) -> FitResult:
        revalidated.append(result)
        return _result(result.spec, 0.45)

    out = eliminate(steps, _trial(lattice_spec, "quantization"), _without({"coupled_mode": 0.6}, []), revalidate, 1)
    assert revalidated == [read]
    assert out.dropped == [] and [s.judgement.effect for s in out.steps] == ["coupled_mode", "quantization"]


def test_an_effect_another_one_refines_is_not_judged_for_dropping() -> None:
    # static friction is a multiple of the Coulomb level: while it stays, the friction cannot go,
    # however little the final model would miss without it (a model of static friction without
    # a Coulomb level cannot be simulated)
    steps = _chain(["coulomb_friction", "static_friction", "cubic_stiffness"], [1.0, 0.7, 0.6, 0.5])
    calls: list[tuple[str, int]] = []
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "cubic_stiffness"),
                    _without({"coulomb_friction": 0.5, "static_friction": 0.7}, calls), _no_revalidation, 1)
    assert [s.judgement.effect for s in out.steps] == ["coulomb_friction", "static_friction", "cubic_stiffness"]
    assert ("coulomb_friction", 2) not in calls and ("static_friction", 2) in calls
