"""Cases the red team's generator drew at seeds this code was not written against (400-403):
each failed before the change it names.

The generator is `tools/redteam/cases11.py` and `cases11b.py` (written from the issues and the
physics only, independent of the package); the truth is used only in the assertions.

- A motor pulse pushing a cart with dry friction (`coulomb+force_pulse`): the duty is held from
  sample to sample and switches between the diagnosis' work samples; read at the work samples
  and interpolated, its edges were smeared and moved by up to a step, and the fit stopped 0.5-5
  points under the noise floor with the friction 7-57 % off.
- Flicks read through a 1.1-1.4 mm lattice (`viscous+coulomb` 402, `coulomb+held_cart` 400):
  the hand's push passed the finder's limit only at its peak, for less than a tenth of a
  period, and no release was found (the diagnosis then fitted the hand's push: 54.7 %).
- A 2 mm lattice whose last rest ends with the record (`quantization_edges` 401): `ident
  releases` and `ident diagnose` raised `ValueError: v cannot be empty`.
- Two carts with dry friction read through cart 1's encoder at 75 Hz (`two_cart_coulomb_y1`
  502): a first-round candidate's simulation ran off (NaN positions), its fit % was taken for
  'every output constant' and the whole diagnosis was refused.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import ident.diagnose.run as run_module
from ident.cli import main
from ident.diagnose import diagnose
from ident.releases import find_releases
from testkit.redteam import redteam_module


def _case(family: str, seed: int) -> Any:
    return redteam_module("run11").case_of(family, seed)   # both generators' families


def _noise_floor(case: Any, start: float, stop: float, column: int = 0) -> float:
    """The fit % of the noiseless positions of `column` to its readings over [start, stop] (what
    a perfect model reaches)."""
    sel = (case.t >= start) & (case.t <= stop)
    y, x = case.y[sel, column], case.x[sel, column]
    return float(100 * (1 - np.linalg.norm(y - x) / np.linalg.norm(y - y.mean())))


@pytest.mark.parametrize("seed", [400, 401, 402, 403])
def test_a_motor_pulse_on_a_cart_with_dry_friction_is_fitted_to_its_noise_floor(seed: int) -> None:
    case = _case("coulomb+force_pulse", seed)
    report = diagnose(case.t, case.y, 1, 0.0, u=case.u).report
    names = [e.effect for e in report.effects]
    assert report.cause == "coulomb_friction" and "coupled_mode" not in names, names
    friction = next(e for e in report.effects if e.effect == "coulomb_friction").parameters["coulomb_accel_m_s2"]
    truth = float(case.truth["coulomb_accel_m_s2"])
    assert abs(friction / truth - 1.0) < 0.05, (friction, truth)
    floor = _noise_floor(case, report.window_start_s, report.window_end_s)
    assert report.extended.fit_percent > floor - 0.3, (report.extended.fit_percent, floor)


@pytest.mark.parametrize(("family", "seed"), [("viscous+coulomb", 402), ("coulomb+held_cart", 400),
                                              ("quantization_edges", 401),
                                              # unseen seeds 700-703: 1.3-2 mm lattices with noise
                                              # before or after them; the derivatives' noise hid
                                              # the hand over a tenth of a period, and a 30 mm
                                              # swing fell short of 30 stds of the raw readings
                                              ("quantization_edges", 703), ("coupled_light", 703),
                                              ("none", 701), ("viscous+coulomb", 700)])
def test_a_release_read_through_a_coarse_lattice_is_found(family: str, seed: int) -> None:
    case = _case(family, seed)
    releases = find_releases(case.t, case.y)
    truth = float(case.truth["release_time_s"])
    assert len(releases) == 1 and abs(releases[0].release_time_s - truth) < 0.15, \
        ([r.release_time_s for r in releases], truth)


def test_a_candidate_whose_simulation_runs_off_is_listed_as_not_fitted(monkeypatch: pytest.MonkeyPatch) -> None:
    # the case ran a first-round candidate off while the diagnosis dated the release itself; fitted
    # from the release `ident.releases` dates, none runs off there, so one is made to: its
    # positions not finite, as a strong cubic's or two sticking carts' simulation can end
    case = _case("two_cart_coulomb_y1", 502)
    (release,) = find_releases(case.t, case.y)
    forward = run_module.forward

    def one_runs_off(*args: Any, **kwargs: Any) -> Any:
        selection = forward(*args, **kwargs)
        first, *rest = selection.first_round
        broken = dataclasses.replace(first.result, prediction=np.full_like(first.result.prediction, np.nan))
        return dataclasses.replace(selection, first_round=[dataclasses.replace(first, result=broken), *rest])

    monkeypatch.setattr(run_module, "forward", one_runs_off)
    report = diagnose(case.t, case.y, 2, None, start_s=release.release_time_s, stop_s=release.end_time_s).report
    assert report.cause == "coulomb_friction"
    assert all(np.isfinite(c.fit_percent) and np.isfinite(c.gain_points) for c in report.candidates)
    ran_off = [c for c in report.candidates if "ran off" in c.note]
    assert ran_off and all(c.gain_points == 0.0 and not c.significant for c in ran_off), report.candidates


def _record(seed: int) -> Any:
    cases10 = redteam_module("cases10")
    return cases10, cases10.make_record(seed)


def _readings(seed: int, handling: bool = False) -> tuple[Any, np.ndarray, np.ndarray]:
    """An issue-10 red-team record, its times (s: the ECP clock counts whole ms) and positions
    (m), as `ident releases` reads them."""
    cases10 = redteam_module("cases10")
    rec = cases10.make_record(seed, handling=handling)
    t = np.asarray(rec.t, dtype=np.float64)
    t = t / 1000.0 if rec.t.dtype.kind in "iu" else t
    return rec, t, np.asarray(rec.counts, dtype=np.float64) / cases10.COUNTS_PER_M


def _record_311() -> Any:
    return _record(311)


def test_a_cart_that_creeps_at_its_last_turn_is_diagnosed_to_its_stop(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """Issue-10 red-team record 311 (100 Hz, a stiff spring, friction that stops a swing in a
    few cycles, static up to 1.5x kinetic): at each ringing's last turn the spring barely beats
    static friction and the cart creeps back 0.5 mm in 90 ms before it sticks. That turn read as
    a sustained push (a touch) and ended each release's window 0.1 s before the stop: 45-47
    samples, too few to diagnose. Every release is now diagnosed, with dry friction."""
    cases10, rec = _record_311()
    path = tmp_path / "rec311.csv"
    path.write_text(cases10.csv_text(rec))
    assert main(["releases", str(path), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert len(listed) == len(rec.releases) == 4
    assert main(["diagnose", str(path), "--all", "--json", "-q"]) == 0
    reports = json.loads(capsys.readouterr().out)
    assert len(reports) == 4
    assert all("coulomb_friction" in [e["effect"] for e in r["effects"]] and r["gain_points"] > 0 for r in reports)


def test_diagnose_all_goes_on_past_a_release_too_short_to_diagnose(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """Record 311 with its third release grabbed again 0.24 s (24 samples) after the let-go (the
    cart held still there until the next flick): too few samples to diagnose. `ident diagnose
    --all` had refused a whole record for one such release; each short one is named on stderr
    and the others are reported."""
    cases10, rec = _record_311()
    third = rec.releases[2]["t_r"]
    grab = (rec.t >= third + 0.24) & (rec.t < rec.releases[3]["t_r"] - 0.5)
    rec.counts[grab, :] = rec.counts[np.flatnonzero(grab)[0], :]
    path = tmp_path / "rec311_grabbed.csv"
    path.write_text(cases10.csv_text(rec))
    assert main(["releases", str(path), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert main(["diagnose", str(path), "--all", "--json", "-q"]) == 0
    captured = capsys.readouterr()
    reports = json.loads(captured.out)
    skipped = [line for line in captured.err.splitlines() if "not diagnosed" in line]
    assert reports and skipped and len(reports) + len(skipped) == len(listed), (len(listed), captured.err)
    assert all("at least 25 samples" in line for line in skipped)
    assert any(f"at {third:.2f}" in line for line in skipped), (third, skipped)
    assert all("coulomb_friction" in [e["effect"] for e in r["effects"]] for r in reports)


@pytest.mark.parametrize("seed", [504, 507])
def test_a_short_ringing_at_50_hz_is_diagnosed(tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: int) -> None:
    """Issue-10 red-team records at 50 Hz (unseen seeds 500-515): in 507 friction stops the
    first release's cart in three cycles, 49 samples before the held cart's wander ends its
    window; in 504 the student grabs the second release's cart again two periods after the
    let-go, 31 samples. A diagnosis needed 50 and named neither; five per blocked-CV block
    (25) suffice, and both come out with dry friction, as every other release of the records."""
    cases10, rec = _record(seed)
    path = tmp_path / f"rec{seed}.csv"
    path.write_text(cases10.csv_text(rec))
    assert main(["releases", str(path), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert min(r["end_time_s"] - r["release_time_s"] for r in listed) < 1.0
    assert main(["diagnose", str(path), "--all", "--json", "-q"]) == 0
    captured = capsys.readouterr()
    reports = json.loads(captured.out)
    assert len(reports) == len(listed), captured.err
    assert all("coulomb_friction" in [e["effect"] for e in r["effects"]] and r["gain_points"] > 0 for r in reports)


def test_a_second_mode_read_through_a_coarse_lattice_is_kept() -> None:
    """Red team `coupled_pinned` 700 (unseen seeds 700-703): a second cart of the same mass
    pinned by a stiff spring rings at 5.7 Hz in cart 1's 0.41 mm encoder. The mode was taken
    (+1.05 points), then the lattice; backward elimination judged the mode held out on refits
    through the lattice's staircase (ratio -41 against 29), dropped it, and named the lattice.
    Judged held out on the carts' model without the lattice and read through the lattice on the
    whole window, it stays, material; the lattice comes after it, credited with what it costs
    a perfect reading of the record (1.94 points, more than the mode's 1.05: the headline)."""
    case = _case("coupled_pinned", 700)
    release = find_releases(case.t, case.y)[0]
    report = diagnose(case.t, case.y, 1, None, start_s=release.release_time_s, stop_s=release.end_time_s).report
    effects = {e.effect: e for e in report.effects}
    mode, lattice = effects["coupled_mode"], effects["quantization"]
    assert mode.material and mode.step < lattice.step
    assert mode.parameters["mode_hz"] == pytest.approx(case.truth["mode_hz"], rel=0.05)
    # (the truth's worth is over the record to its end; the window is cut in its still tail)
    assert lattice.gain_points == pytest.approx(case.truth["lattice_worth_points"], rel=0.1)
    assert report.cause == max(report.effects, key=lambda e: e.gain_points).effect
    assert all(e.gain_points > 0 for e in report.effects)


@pytest.mark.parametrize("seed", [1014, 1120])
def test_a_hold_on_a_coarse_clock_is_dated_where_the_hand_lets_go(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str],
                                                                   seed: int) -> None:
    """Issue-10 red-team records 1014 and 1120 (ECP's whole-millisecond clock, drawn 2026-11-28):
    a hold let go at 80-120 m/s² was dated 23-25 ms late. Within 10 ms of the let-go the cart
    runs at 1 m/s, where a stamp up to a millisecond off misplaces it by up to a millimetre:
    single samples of the fine residual stood at 4 noise widths 8 and 20 ms after the force had
    ended, and the force was taken to last until them."""
    cases10, rec = _record(seed)
    path = tmp_path / f"rec{seed}.csv"
    path.write_text(cases10.csv_text(rec))
    assert main(["releases", str(path), "--json"]) == 0
    found = [r["release_time_s"] for r in json.loads(capsys.readouterr().out)]
    truth = [float(r["t_r"]) for r in rec.releases]
    assert len(found) == len(truth)
    assert abs(found[0] - truth[0]) <= 0.0015, (found[0], truth[0])   # the clock's step: 1-2 ms


def test_a_fast_second_mode_of_two_frictional_carts_is_the_chains_own() -> None:
    """Red team `two_cart_coulomb_y12` 1010 (unseen seeds 1010-1012, both encoders): a light cart
    2 (0.54 kg) on a stiff wall spring rings at 6.6 Hz beside the 2 Hz mode, its ring stopped by
    dry friction (0.33 m/s²) within a few cycles. The linear chain's best fit imitates friction's
    straight decay by a beat of two modes at 11.8 and 12.8 rad/s; friction started in that chain
    and a 6.6 Hz 'coupled mode' was taken as the headline, 6 points under the noise floor and
    cart 2's friction 95 % off. Friction is now also started in the chains of the baseline's
    other starts."""
    case = _case("two_cart_coulomb_y12", 1010)
    release = find_releases(case.t, case.y)[0]
    report = diagnose(case.t, case.y, 2, None, start_s=release.release_time_s, stop_s=release.end_time_s).report
    found = [e.effect for e in report.effects]
    assert report.cause == "coulomb_friction" and "coupled_mode" not in found, found
    friction = next(e for e in report.effects if e.effect == "coulomb_friction").parameters
    assert friction["coulomb_accel_m_s2"] == pytest.approx(case.truth["coulomb_accel_m_s2"], rel=0.05)
    assert friction["coulomb_accel_m_s2_cart2"] == pytest.approx(case.truth["coulomb_accel_m_s2_cart2"], rel=0.05)
    tr = case.truth
    stiffness = np.array([[tr["k1"] + tr["k2"], -tr["k2"]], [-tr["k2"], tr["k2"] + tr["k3"]]])
    true_modes = np.sqrt(np.sort(np.linalg.eigvals(stiffness / np.array([[tr["m"]], [tr["m2"]]])).real))
    modes = sorted(report.corrected_linear[k] for k in ("wn_mode1_rad_s", "wn_mode2_rad_s"))
    assert modes == pytest.approx(true_modes, rel=0.05)


def test_a_light_cart_read_beside_a_heavy_one_is_started_in_its_own_chain() -> None:
    """Red team `two_cart_coulomb_y1` 1038 (unseen seeds 1014-1039, cart 1's encoder only, 91 Hz):
    a light cart 1 (0.67 kg) on stiff springs rings at 44.6 rad/s, the heavy cart 2 (2.5 kg) at
    13.5. The linear fit put both modes near 44.6, every friction start lay in that chain, and
    the fit ended 8.5 points under the noise floor with cart 2's friction pinned 4000x too
    strong. The friction fit now also starts with either mode kept and the other 1/8-8 times
    its wn². (Cart 2's friction, read through a 0.19 mm lattice, is 7 % off from the case's CSV
    and 23 % off from its arrays: the data hardly fix it, and it is not asserted.)"""
    case = _case("two_cart_coulomb_y1", 1038)
    release = find_releases(case.t, case.y)[0]
    report = diagnose(case.t, case.y, 2, None, start_s=release.release_time_s, stop_s=release.end_time_s).report
    floor = _noise_floor(case, report.window_start_s, report.window_end_s)
    assert report.extended.fit_percent >= floor - 0.3, (report.extended.fit_percent, floor)
    friction = next(e for e in report.effects if e.effect == "coulomb_friction").parameters
    assert friction["coulomb_accel_m_s2"] == pytest.approx(case.truth["coulomb_accel_m_s2"], rel=0.05)


@pytest.mark.parametrize("seed", [701, 706])
def test_handling_let_go_where_the_cart_stays_is_no_release(seed: int) -> None:
    """Issue-10 red-team handling records 701 and 706 (unseen seeds 700-709, 100 Hz, 60 s, no
    release): nudges, moves of the held cart and slow pulls, each let go where the cart stays.
    With no ringing in the record its dominant period came out at 4.4 s; over a period after
    two nudges (701) the slow pulls that followed counted as 17 mm swings, and a slow pull's
    return by hand (706) as a 22 mm swing that stopped at its first turn: each was listed as a
    release. A released cart leaves at once and swings back from its first turn."""
    _, t, y = _readings(seed, handling=True)
    assert find_releases(t, y) == []


@pytest.mark.parametrize(("family", "seed"), [("coulomb+force_pulse", 700), ("coulomb+held_cart", 700),
                                              ("two_cart_coulomb_y1", 700)])
def test_a_mode_worth_a_hundredth_of_a_point_under_a_friction_fit_is_immaterial(family: str, seed: int) -> None:
    """Red team 700 (a motor pulse on a cart with dry friction, a flick with a held cart, two
    carts through one encoder): the friction model gains 6-13 points and fits to within the
    noise; a 0.9-7 Hz 'mode' of 2-30 µm then passes the noise bound and takes a tenth of the
    little misfit left (+0.008-0.015 points), and was listed as a material coupled mode. It is
    now immaterial: it took a ten-thousandth of what the diagnosis explained."""
    case = _case(family, seed)
    carts = 2 if family == "two_cart_coulomb_y1" else None   # as `ident diagnose` is given it
    report = diagnose(case.t, case.y, carts, u=case.u).report
    assert report.cause == "coulomb_friction"
    material = [e.effect for e in report.effects if e.material]
    assert "coupled_mode" not in material, [(e.effect, e.gain_points, e.material) for e in report.effects]


def test_a_hold_release_of_a_cart_with_a_strong_second_mode_is_dated_at_the_let_go() -> None:
    """Red team `coupled_span` 1500 (unseen seeds 1500-1507): a 2.8 kg cart held still 55 mm
    out, a 0.75 kg cart coupled to it and pinned (a 3.6 Hz mode beside the 2.1 Hz one, 12 % of
    the swing). 80 ms after the let-go the second mode's misfit reached 0.4 of the spring's
    force and read as a hand taking the cart again: the hold was judged handling and the
    release dated 141 ms late, at that misfit, its first swing lost."""
    case = _case("coupled_span", 1500)
    releases = find_releases(case.t, case.y)
    step = float(np.median(np.diff(case.t)))
    assert len(releases) == 1
    assert abs(releases[0].release_time_s - case.truth["release_time_s"]) <= step, releases[0].release_time_s


def test_a_hold_while_the_held_cart_is_moved_still_ends_in_a_release() -> None:
    """Issue-10 red-team record 1509 (unseen seeds 1500-1529, 50 Hz): the student holds cart 2
    pulled 55 mm while the other hand moves cart 1 by 13 mm, then lets cart 2 go. The held
    cart moved by more than a fifth of the pulled one and beyond its wander, and the hold was
    taken for a touch of it: the release was lost. The hand pushed 33 m/s², eight times what the
    held cart's move pulls through the spring."""
    rec, t, y = _readings(1509)
    found = [r.release_time_s for r in find_releases(t, y)]
    truths = [float(r["t_r"]) for r in rec.releases]
    assert len(found) == len(truths) == 3, (found, truths)
    assert all(abs(f - r) <= 0.02 for f, r in zip(found, truths)), (found, truths)


def test_a_flick_braked_to_its_path_end_and_held_there_is_dated_at_the_let_go() -> None:
    """Red team `quantization` 1500 (176 Hz, an 84 µm lattice with noise after it): the hand
    flicks the cart 45 mm out, brakes it to rest at the end of its path and holds it there
    a moment. Its force passed through zero while braking and stayed under the limit for 51 ms,
    then held back at up to 2.5 limits for the 40 ms before the let-go; the release was dated
    at the zero crossing, 83 ms early, and the diagnosis took the hand's hold for a 2.5 Hz
    mode (+0.56 points)."""
    case = _case("quantization", 1500)
    releases = find_releases(case.t, case.y)
    step = float(np.median(np.diff(case.t)))
    assert len(releases) == 1
    assert abs(releases[0].release_time_s - case.truth["release_time_s"]) <= 1.5 * step, releases[0].release_time_s


def test_a_flick_held_again_at_its_path_end_is_dated_at_the_let_go() -> None:
    """Red team `coulomb+quantization` 10701 (178 Hz, a 0.13 mm lattice with noise before it):
    the hand's push faded as the cart neared the end of its path, and the hand held it there
    again for the 40 ms before the let-go at 1.55 times the fine residual's limit. It was dated
    where the push faded, 47 ms (8 samples) early, and the diagnosis named a spurious coupled
    mode and put ζ 17 % off."""
    case = _case("coulomb+quantization", 10701)
    releases = find_releases(case.t, case.y)
    step = float(np.median(np.diff(case.t)))
    assert len(releases) == 1
    assert abs(releases[0].release_time_s - case.truth["release_time_s"]) <= step, releases[0].release_time_s


def test_a_second_mode_under_a_lattice_is_kept_through_the_elimination(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    """Red team `coupled_span` 2000 (unseen seeds 2000-2002; 266 Hz, a 0.88 mm lattice worth
    1.2 points), as `ident diagnose FILE` sees it: the 4.6 Hz mode came in, a later step's
    backward elimination dropped it, and the diagnosis ended with a 0.05-point cubic spring
    at 98.78 %, worse than before that step; the step is now undone (`backward.settle`) and
    the mode stays (99.38 %)."""
    case = _case("coupled_span", 2000)
    path = tmp_path / "coupled_span_2000.csv"
    redteam_module("run11").write_csv(case, path)   # as the red team's runner writes it
    assert main(["diagnose", str(path), "--scale", "1", "--json", "-q"]) == 0
    report = json.loads(capsys.readouterr().out)
    modes = [e["parameters"]["mode_hz"] for e in report["effects"] if e["effect"] == "coupled_mode"]
    assert len(modes) == 1 and abs(modes[0] / case.truth["mode_hz"] - 1.0) < 0.05, \
        ([(e["effect"], e["gain_points"]) for e in report["effects"]], case.truth["mode_hz"])


def test_a_held_carts_coupling_read_through_a_lattice_stays_when_static_friction_fails_only_held_out(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Red team `coulomb+held_cart` 2202 (unseen seeds 2200-2202; 69 Hz, a 0.35 mm lattice, a
    held cart wandering 2.6 mm): static friction came in third (held out 51 on a bound of 11),
    the held cart's coupling fourth (128). Backward elimination then dropped static friction,
    held out -75 on the carts' model without the lattice although the whole window needed it
    (ratio 732); read through the lattice the model without it cost 155 times the final
    model's, and `settle` undid the coupling too. The coupling is the family's effect. As
    `ident diagnose FILE` sees it."""
    case = _case("coulomb+held_cart", 2202)
    path = tmp_path / "coulomb_held_cart_2202.csv"
    redteam_module("run11").write_csv(case, path)
    assert main(["diagnose", str(path), "--scale", "1", "--json", "-q"]) == 0
    report = json.loads(capsys.readouterr().out)
    effects = {e["effect"]: e for e in report["effects"]}
    assert report["cause"] == "coulomb_friction" and "held_cart_motion" in effects, list(effects)
    friction = effects["coulomb_friction"]["parameters"]["coulomb_accel_m_s2"]
    assert friction == pytest.approx(case.truth["coulomb_accel_m_s2"], rel=0.05)


@pytest.mark.parametrize("seed", [9623, 9700])
def test_a_stuck_cart_the_held_cart_drags_to_a_new_level_has_its_coupling(tmp_path: Path,
                                                                           capsys: pytest.CaptureFixture[str],
                                                                           seed: int) -> None:
    """Red team `coulomb+held_cart` 9700 (unseen seeds 9600-9623 and 9700-9703; 73 Hz, a held
    cart on a critically damped hand wandering 5 mm, kinetic friction 0.65 m/s² for 17 cycles)
    and 9623: the wander drags the stuck cart to a new level seconds after it stopped, and the
    rest of the record shows the coupling little. Every start of the coupling's screen (β at
    0.05-0.5 wn², the rest and frequency where the friction model had them) ended worse than no
    coupling, and the fit stopped 1.85 (1.56) points under its noise floor with only friction
    and the lattice named. The coupling's profile (`held_fit._profile_start`: the pull's
    parts along the model's own terms moved into them) starts it in its basin."""
    case = _case("coulomb+held_cart", seed)
    path = tmp_path / f"coulomb_held_cart_{seed}.csv"
    redteam_module("run11").write_csv(case, path)
    assert main(["diagnose", str(path), "--scale", "1", "--json", "-q"]) == 0
    report = json.loads(capsys.readouterr().out)
    effects = {e["effect"]: e for e in report["effects"]}
    assert report["cause"] == "coulomb_friction" and "held_cart_motion" in effects, list(effects)
    floor = _noise_floor(case, report["window_start_s"], report["window_end_s"], column=1)   # the released cart
    assert report["extended"]["fit_percent"] > floor - 0.3, (report["extended"]["fit_percent"], floor)
