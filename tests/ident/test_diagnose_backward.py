"""Backward elimination: an earlier effect the final model no longer needs is dropped.

Judged as the forward selection judges an extension (`select.judge`): the final model against
the final model refitted without the effect, on the whole window and held out, with the same
bound and the BIC. The costs here are given (the logic under test is the decision, not a fit):
N = 500 residuals, one cart; an effect of 1 parameter needs n ln(SSE ratio) > χ²₁(0.999) =
10.83, a 2 % cut in cost (n ln(1/0.98) = 10.1 fails, 3 % = 15.2 passes).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest

from ident.diagnose.backward import eliminate, settle
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


def test_an_early_effect_the_final_model_does_not_need_is_dropped_and_the_rest_kept() -> None:
    # drag first (1.0 -> 0.7), then friction (0.7 -> 0.5); the final model refitted without the
    # drag costs 0.505 (1 %: the friction explains what the drag stood in for), without both
    # 1.0 (the linear model's own best fit is the baseline)
    steps = _chain(["quadratic_drag", "coulomb_friction"], [1.0, 0.7, 0.5])
    calls: list[tuple[str, int]] = []
    last = _trial(steps[-1].judgement.result.spec, "coulomb_friction")
    out = eliminate(steps, last, _without({"quadratic_drag": 0.505, "coulomb_friction": 1.0}, calls), 1)
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


def test_after_a_drop_the_last_effect_is_credited_from_its_refit_when_that_fits_better() -> None:
    # drag (1.0 -> 0.9), mode (0.9 -> 0.8), cubic (0.8 -> 0.5): the final model refitted without
    # the drag or the mode costs 0.502 (neither needed), without the cubic 0.51: the refits had
    # moved the others to a better optimum, and the cubic itself adds 2 %. Handed the dropped
    # steps' model before (1.0) it would be credited 1.0 -> 0.502; it is credited 0.51 -> 0.502,
    # as the forward selection credits an effect whose refit without it beats its model before
    steps = _chain(["quadratic_drag", "coupled_mode", "cubic_stiffness"], [1.0, 0.9, 0.8, 0.5])
    calls: list[tuple[str, int]] = []
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "cubic_stiffness"),
                    _without({"quadratic_drag": 0.502, "coupled_mode": 0.502, "cubic_stiffness": 0.51}, calls), 1)
    assert [s.judgement.effect for s in out.steps] == ["cubic_stiffness"]
    assert out.steps[0].before.sse_train == pytest.approx(0.51)
    assert out.steps[0].judgement.result.sse_train == pytest.approx(0.502)
    assert ("cubic_stiffness", 1) in calls


def test_effects_the_final_model_needs_are_all_kept() -> None:
    steps = _chain(["quadratic_drag", "coulomb_friction"], [1.0, 0.7, 0.5])
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "coulomb_friction"),
                    _without({"quadratic_drag": 0.6, "coulomb_friction": 0.7}, []), 1)
    assert [s.judgement.effect for s in out.steps] == ["quadratic_drag", "coulomb_friction"]
    assert out.dropped == [] and out.steps == steps


def test_of_two_unneeded_effects_the_weaker_goes_first_and_the_other_is_judged_again() -> None:
    # drag and cubic both stand in for the friction; without the drag the cost rises 0.4 %,
    # without the cubic 1.2 %: the drag (weaker) is dropped; then the cubic, judged again on
    # the smaller model (the same stub costs), is dropped too
    steps = _chain(["quadratic_drag", "cubic_stiffness", "coulomb_friction"], [1.0, 0.8, 0.7, 0.5])
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "coulomb_friction"),
                    _without({"quadratic_drag": 0.502, "cubic_stiffness": 0.506, "coulomb_friction": 0.7}, []), 1)
    assert [j.effect for j in out.dropped] == ["quadratic_drag", "cubic_stiffness"]
    assert [s.judgement.effect for s in out.steps] == ["coulomb_friction"]


def _without_models(costs: Mapping[tuple[str, ...], float | tuple[float, float]],
                    calls: list[tuple[tuple[str, ...], int]]):
    """`without` whose refitted model costs `costs[its effects]` (whole window and held out,
    or the pair (whole window, held out))."""
    def without(trial: Trial, result: FitResult, refit: int) -> FitResult:
        assert refit, "every model here is refitted"
        effects = tuple(e for e in result.spec.effects if e != trial.effect)
        assert trial.lower.size == result.theta.size   # the bounds are the model's own
        calls.append((effects, refit))
        cost = costs[effects]
        whole, held_out = cost if isinstance(cost, tuple) else (cost, cost)
        return _result(ModelSpec(effects, 1), whole, held_out)
    return without


def _mode_then_lattice() -> tuple[list[Step], ModelSpec]:
    """A mode (1.0 -> 0.6), then an encoder lattice whose held-out cost is the lattice's reading
    of the carts' held-out predictions (3x its whole-window cost, 0.45)."""
    spec = ModelSpec((), 1)
    linear = _result(spec, 1.0)
    mode = _result(spec.with_effect("coupled_mode"), 0.6)
    lattice_spec = spec.with_effect("coupled_mode").with_effect("quantization")
    read = _result(lattice_spec, 0.45, sse_val=1.35)
    return [Step(judge("coupled_mode", linear, mode, 1), linear),
            Step(Judgement("quantization", read, 200.0, 150.0, 27.0, 190.0), mode)], lattice_spec


def test_a_mode_under_a_lattice_is_judged_held_out_without_the_lattice_and_kept() -> None:
    # held out, the carts' model without the lattice needs the mode (0.6 -> 1.0), and read
    # through the lattice the whole window does too (0.45 -> 0.7): kept, although against the
    # lattice-read held-out cost (1.35) a refit without the mode (0.7) would look better
    steps, spec = _mode_then_lattice()
    calls: list[tuple[tuple[str, ...], int]] = []
    costs = {("coupled_mode",): 0.6, (): 1.0, ("quantization",): 0.7}
    out = eliminate(steps, _trial(spec, "quantization"), _without_models(costs, calls), 1)
    assert out.dropped == [] and [s.judgement.effect for s in out.steps] == ["coupled_mode", "quantization"]
    assert ((), 2) in calls and (("quantization",), 1) in calls


def test_a_mode_the_lattice_explains_is_dropped() -> None:
    # held out without the lattice the mode still gains (0.6 -> 0.66, ratio 48 against the
    # searched bound of ~29), but read through the lattice the whole window without it costs
    # 0.46 against 0.45 (ratio 11): the lattice explains what the mode fitted
    steps, spec = _mode_then_lattice()
    costs = {("coupled_mode",): 0.6, (): 0.66, ("quantization",): 0.46}
    out = eliminate(steps, _trial(spec, "quantization"), _without_models(costs, []), 1)
    assert [j.effect for j in out.dropped] == ["coupled_mode"]
    assert [s.judgement.effect for s in out.steps] == ["quantization"]
    assert out.steps[0].judgement.result.spec.effects == ("quantization",)


@pytest.mark.parametrize(("read_without", "kept"), [(0.7, True), (0.46, False)])
def test_an_effect_that_fails_held_out_under_a_lattice_goes_only_when_the_lattice_read_does_without_it(
        read_without: float, kept: bool) -> None:
    # held out, the carts' model without the lattice does as well without the mode (0.59
    # against 0.6: a refit without a block can land elsewhere, as a dry-friction fit's stick
    # decisions do), while the whole window needs it (1.0 -> 0.6). Read through the lattice the
    # whole window needs it too (0.7 -> 0.45): kept. Red team coulomb+held_cart 2202 (69 Hz,
    # 0.35 mm lattice): static friction, whole-window ratio 732 and held out -75, was dropped,
    # the refit without it through the lattice cost 155 times the final model's, and the held
    # cart's coupling that came after it was undone with it. When the lattice read does
    # without it too (0.46 against 0.45), it goes.
    steps, spec = _mode_then_lattice()
    costs: dict[tuple[str, ...], float | tuple[float, float]] = {
        ("coupled_mode",): 0.6, (): (1.0, 0.59), ("quantization",): read_without}
    out = eliminate(steps, _trial(spec, "quantization"), _without_models(costs, []), 1)
    assert [s.judgement.effect for s in out.steps] == (["coupled_mode", "quantization"] if kept else ["quantization"])
    assert [j.effect for j in out.dropped] == ([] if kept else ["coupled_mode"])


def test_an_effect_another_one_refines_is_not_judged_for_dropping() -> None:
    # static friction is a multiple of the Coulomb level: while it stays, the friction cannot go,
    # however little the final model would miss without it (a model of static friction without
    # a Coulomb level cannot be simulated)
    steps = _chain(["coulomb_friction", "static_friction", "cubic_stiffness"], [1.0, 0.7, 0.6, 0.5])
    calls: list[tuple[str, int]] = []
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "cubic_stiffness"),
                    _without({"coulomb_friction": 0.5, "static_friction": 0.7}, calls), 1)
    assert [s.judgement.effect for s in out.steps] == ["coulomb_friction", "static_friction", "cubic_stiffness"]
    assert ("coulomb_friction", 2) not in calls and ("static_friction", 2) in calls


def test_after_a_drop_every_later_step_is_credited_along_one_chain_without_the_dropped_effect() -> None:
    # drag (1.0 -> 0.7), friction (0.7 -> 0.5), cubic (0.5 -> 0.45); the final model needs no
    # drag (0.452 without it). The friction's and the cubic's forward models held the drag: a
    # credit within them (0.5 -> 0.452 for the cubic, the old one) is not what the effect adds
    # to the diagnosis's model, and the credits would not add up to its gain (1.0 -> 0.452)
    steps = _chain(["quadratic_drag", "coulomb_friction", "cubic_stiffness"], [1.0, 0.7, 0.5, 0.45])
    costs = {("coulomb_friction", "cubic_stiffness"): 0.452, ("quadratic_drag", "cubic_stiffness"): 0.9,
             ("cubic_stiffness",): 0.9, ("coulomb_friction",): 0.6, (): 1.0}
    calls: list[tuple[tuple[str, ...], int]] = []
    out = eliminate(steps, _trial(steps[-1].judgement.result.spec, "cubic_stiffness"),
                    _without_models(costs, calls), 1)
    assert [j.effect for j in out.dropped] == ["quadratic_drag"]
    friction, cubic = out.steps
    assert cubic.judgement.result.sse_train == pytest.approx(0.452)
    assert cubic.before.spec.effects == ("coulomb_friction",) and cubic.before.sse_train == pytest.approx(0.6)
    assert friction.judgement.result is cubic.before and friction.before is steps[0].before
    for step in out.steps:
        assert "quadratic_drag" not in step.before.spec.effects + step.judgement.result.spec.effects


def test_drops_that_leave_the_model_worse_than_before_the_last_step_undo_that_step() -> None:
    # drag (1.0 -> 0.7), cubic (-> 0.6), friction last (-> 0.59). Without the drag the final
    # model costs 0.595 (within the noise: dropped); then without the cubic 0.605 (within the
    # noise of 0.595: dropped too), worse than the 0.6 the model had before the friction came
    # in: the friction's step gained nothing net, so it is undone, and of drag and cubic (the
    # model without the drag costs 0.68 there) both stay
    costs = {frozenset({"quadratic_drag", "cubic_stiffness", "coulomb_friction"}): 0.59,
             frozenset({"cubic_stiffness", "coulomb_friction"}): 0.595,
             frozenset({"quadratic_drag", "coulomb_friction"}): 0.62,
             frozenset({"coulomb_friction"}): 0.605, frozenset({"cubic_stiffness"}): 0.68,
             frozenset({"quadratic_drag"}): 0.7, frozenset(): 1.0}

    def without(trial: Trial, result: FitResult, refit: int) -> FitResult:
        left = tuple(e for e in result.spec.effects if e != trial.effect)
        return _result(ModelSpec(left, 1), costs[frozenset(left)] if refit else 1.5 * result.sse_train)

    steps = _chain(["quadratic_drag", "cubic_stiffness", "coulomb_friction"], [1.0, 0.7, 0.6, 0.59])
    last = _trial(steps[-1].judgement.result.spec, "coulomb_friction")
    plain = eliminate(steps, last, without, 1)
    assert [s.judgement.effect for s in plain.steps] == ["coulomb_friction"]
    assert plain.steps[-1].judgement.result.sse_train == pytest.approx(0.605)
    out = settle(steps, last, without, 1)
    assert [s.judgement.effect for s in out.steps] == ["quadratic_drag", "cubic_stiffness"]
    assert out.steps[-1].judgement.result.sse_train == pytest.approx(0.6) and out.dropped == []
    assert out.last.lower.size == len(out.steps[-1].judgement.result.spec.names)
