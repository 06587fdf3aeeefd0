"""Issue 11's targets for `ident diagnose` on a fast seeded subset of independent cases.

The cases come from `testkit.effects` (its own physics and integrator, no `ident` import),
three per family, seeds drawn once from a fixed set seed (never picked). `diagnose` gets
only t, y and the number of carts. Targets (issue 11): the right headline cause, every hidden
parameter within 5 %, no cause or material effect named on a linear run, both effects of a
pair found; two carts with Coulomb friction through one encoder: fit within 0.3 points of
the noise floor, friction within 5 %, release within one sample. The full benchmark with
>= 40 cases per family is `tools/bench_diagnose.py`.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from schemas.diagnosis import DiagnosisReport
from testkit.effects import FAMILIES, PAIRS, Case, Verdict, judge, make_case, noise_floor_percent

SET_SEED = 20261124
PER_FAMILY = 3
#: targets main did not meet when this test landed (strict: a pass fails the run, so the mark
#: is removed as soon as the diagnosis meets them); tools/bench_diagnose.py gives the rates
NOT_YET: dict[str, str] = {}


def _seeds(family: str, n: int = PER_FAMILY) -> list[int]:
    rng = np.random.default_rng([SET_SEED, FAMILIES.index(family)])
    return [int(s) for s in rng.integers(0, 2**31, n)]


def _run(case: Case) -> DiagnosisReport:
    return diagnose(case.observed.t, case.observed.y, carts=case.observed.carts).report


def _describe(case: Case, report: DiagnosisReport, verdict: Verdict) -> str:
    errs = ", ".join(f"{k} {100 * e:.1f} %" for k, e in verdict.errors.items())
    return (f"seed {case.seed} {case.truth.family} carts={case.observed.carts} {case.truth.release} "
            f"{case.truth.rate_hz:.0f} Hz: cause {report.cause}, found {list(verdict.found)}, {errs}")


@pytest.mark.slow
@pytest.mark.parametrize("family", [
    pytest.param(f, marks=pytest.mark.xfail(strict=True, reason=NOT_YET[f])) if f in NOT_YET else f
    for f in FAMILIES])
def test_each_family_is_named_with_its_parameters_within_5_percent(family: str) -> None:
    wrong = []
    for seed in _seeds(family):
        case = make_case(seed, family)
        report = _run(case)
        verdict = judge(case, report)
        if not verdict.right:
            wrong.append(_describe(case, report, verdict))
    assert not wrong, "\n".join(wrong)


#: Generated one-encoder cases (`tools/bench_diagnose.py`'s draw, seeds 17-18) whose friction
#: fit, jumping from the large-amplitude part to every sample, stopped 0.65 and 2.8 points short
#: of the noise floor with a friction 1e6 and 177 % off.
ONE_ENCODER_RUGGED = (695920689, 1392210104)


@pytest.mark.slow
@pytest.mark.parametrize("seeds", [pytest.param(None, id="drawn"), pytest.param(ONE_ENCODER_RUGGED, id="rugged")])
def test_two_carts_with_friction_through_one_encoder_reach_the_noise_floor(seeds: tuple[int, ...] | None) -> None:
    problems = []
    for seed in seeds or _seeds("coulomb_friction", 2):
        case = make_case(seed, "coulomb_friction", carts=2, encoders=1)
        report = _run(case)
        floor = noise_floor_percent(case, report.window_start_s)
        verdict = judge(case, report)
        release_samples = abs(report.release_time_s - case.truth.release_time_s) * case.truth.rate_hz
        if floor - report.extended.fit_percent > 0.3 or not verdict.parameters_ok or release_samples > 1.0:
            problems.append(_describe(case, report, verdict)
                            + f", fit {report.extended.fit_percent:.2f} vs floor {floor:.2f}, "
                              f"release off by {release_samples:.2f} samples")
    assert not problems, "\n".join(problems)


#: Generated one-encoder runs whose friction fit had stopped short of the noise floor:
#: - 61607245 (seed 45's draw): cart 2, four times cart 1's friction on a stiff wall spring,
#:   hardly shows its own mode (17.4 rad/s beside 8.45) through cart 1, and the linear fit's two
#:   close modes (8.05 and 8.76 rad/s) held every friction start: cart 2 was pinned by a stiff
#:   spring, 0.38 points under the floor, friction 48 % off (its release, dated by the scan's
#:   knot on those modes, is still 2.6 samples late, so only the fit and the parameters here);
#: - 2053547375 (seed 48's wide draw): breakaway 1.22 and 1.48 times the kinetic levels; no grid
#:   row of breakaway ratios at the one-level friction fitted better than none (the one level
#:   lies between each cart's kinetic and breakaway levels), 1.08 points under the floor.
ONE_ENCODER_SHORT = ((61607245, False), (2053547375, True))


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "wide"), ONE_ENCODER_SHORT)
def test_one_encoder_friction_fits_that_stopped_short_reach_the_noise_floor(seed: int, wide: bool) -> None:
    case = make_case(seed, "coulomb_friction", carts=2, encoders=1, wide_carts=wide)
    report = _run(case)
    floor = noise_floor_percent(case, report.window_start_s)
    verdict = judge(case, report)
    assert floor - report.extended.fit_percent <= 0.3, _describe(case, report, verdict)
    assert verdict.parameters_ok, _describe(case, report, verdict)


@pytest.mark.slow
def test_a_flick_of_a_cart_carrying_a_sprung_mass_is_fitted_from_where_the_hand_let_go() -> None:
    # bench_diagnose --seed 45, coupled_mode case 36 (a 126 Hz flick, 0.46 kg ringing at 9.7 Hz):
    # the window's own scan dated the release 100 ms early, and the fit that began in the push
    # reached 93.5 % for a 99.83 % floor with the mode 49 % off; `ident releases` dates it 0.4 samples off
    case = make_case(1786414251, "coupled_mode")
    report = _run(case)
    verdict = judge(case, report)
    assert verdict.right, _describe(case, report, verdict)
    assert abs(report.release_time_s - case.truth.release_time_s) * case.truth.rate_hz <= 1.0
    assert float(case.noise_floor_percent()[0]) - report.extended.fit_percent <= 0.3


def test_the_subset_spans_one_and_two_carts_holds_and_flicks() -> None:
    cases = [make_case(seed, family) for family in FAMILIES for seed in _seeds(family)]
    assert {c.observed.carts for c in cases} == {1, 2}
    assert {c.truth.release for c in cases} == {"hold", "flick"}
    assert {c.truth.family for c in cases} == set(FAMILIES) and set(PAIRS) <= set(FAMILIES)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [433647530, 776616176])
def test_a_release_from_a_still_hold_is_dated_where_the_cart_leaves_it(seed: int) -> None:
    # bench_diagnose --seed 45, coulomb_friction cases 4 and 16 (two carts at 411 Hz, one cart at
    # 131 Hz, both released from a still hold): the window's scan dated them 71.6 and 6.4 samples
    # late, and the API took its later instant; `ident releases` dates the hold's onset
    case = make_case(seed, "coulomb_friction")
    report = _run(case)
    assert judge(case, report).right
    assert abs(report.release_time_s - case.truth.release_time_s) * case.truth.rate_hz <= 1.0
