"""`ident.releases.find_releases` on seeded students' records generated from the physics
(`testkit.student_records`: its own stick/slip integrator, independent of the finder).

Flicks and pull-hold-releases, 1–4 per record, nudges, a loosely held cart that wanders and
is touched, records that start in motion, back-to-back releases, the last one cut, at 50,
100, 200 and 1000 Hz. Every true release must be found once (none elsewhere), with the right
pulled cart and the held cart not among the moving ones, at the
simulator's instant within two sample periods or 5 ms (the smoothing of a 50 Hz record spans
a tenth of a period); nothing may be found in records of handling only.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from ident.cli import main
from ident.releases import find_releases
from testkit.effects import make_case
from testkit.student_records import RATES_HZ, StudentRecord, handling_records, student_record, student_records

SEEDS = range(20, 30)


@cache
def _records(seed: int) -> dict[float, StudentRecord]:
    """The seed's record at every rate of `RATES_HZ`, simulated once (the motion does not
    depend on the rate; each is sample for sample `student_record(seed, rate)`)."""
    return student_records(seed, RATES_HZ)


@cache
def _three_releases() -> dict[float, StudentRecord]:
    return student_records(7, RATES_HZ, 3, both_free=False)


@cache
def _handling(seed: int) -> dict[float, StudentRecord]:
    return handling_records(seed, RATES_HZ, 60.0)


def _tolerance(rate_hz: float) -> float:
    return max(2.0 / rate_hz, 0.005)


@pytest.mark.slow
@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_every_release_is_found_once_with_its_instant_and_cart(rate_hz: float) -> None:
    missed, extra, late, total = [], [], [], 0
    for seed in SEEDS:
        rec = _records(seed)[rate_hz]
        found = find_releases(rec.t, rec.y)
        total += len(rec.releases)
        for true in rec.releases:
            near = [r for r in found if abs(r.release_time_s - true.time_s) < 0.25]
            if len(near) != 1:
                missed.append((seed, true.time_s))
                continue
            (hit,) = near
            assert hit.pulled_cart == true.pulled_cart
            if not rec.both_free:
                assert hit.moving_carts == (true.pulled_cart,)
            if abs(hit.release_time_s - true.time_s) > _tolerance(rate_hz):
                late.append((seed, round(true.time_s, 3), round(hit.release_time_s - true.time_s, 4)))
            assert hit.release_time_s < hit.end_time_s
        extra += [(seed, r.release_time_s) for r in found
                  if all(abs(r.release_time_s - true.time_s) >= 0.25 for true in rec.releases)]
    print(f"{rate_hz:g} Hz: {total} releases, missed {missed}, extra {extra}, off {late}")
    # every release found once and nothing elsewhere on these seeds (112 releases over the
    # four rates); on 200 other seeds per rate tools/bench_ident_releases.py finds 99.6-99.8 %
    # with 0 false (a cut hold after a nudge and a flick of two free carts missed); instants
    # within tolerance for 90 % (a flick whose force passes through zero before the hand lets
    # go can be dated a few hundredths early)
    assert missed == [] and extra == []
    assert len(late) <= 0.1 * total


@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_free_responses_end_before_the_next_release(rate_hz: float) -> None:
    rec = _three_releases()[rate_hz]
    found = find_releases(rec.t, rec.y)
    assert len(found) == 3
    for before, true_next in zip(found, rec.releases[1:], strict=False):
        assert before.end_time_s < true_next.time_s - 0.1
    assert found[-1].end_time_s <= rec.t[-1]


@pytest.mark.slow
@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_handling_alone_is_no_release(rate_hz: float) -> None:
    for seed in (1,):
        rec = _handling(seed)[rate_hz]
        assert find_releases(rec.t, rec.y) == []


def test_a_record_that_starts_in_motion_has_no_release_before_the_first_hand() -> None:
    rec = student_record(12, 200.0, 1, both_free=False, start_in_motion=True)
    found = find_releases(rec.t, rec.y)
    assert [round(r.release_time_s, 1) for r in found] == [round(rec.releases[0].time_s, 1)]
    assert abs(found[0].release_time_s - rec.releases[0].time_s) <= _tolerance(200.0)


def test_a_chain_flicked_near_its_extreme_leaves_the_hand_slowly_but_is_released() -> None:
    """Seed 3014 at 100 Hz, both carts free: the pulled cart, let go near its extreme, moves by
    0.18 of its swing within a quarter of the fast mode's period (the slow mode dominates); a
    first rule that a released cart moves by a quarter of its swing there dropped the release."""
    rec = student_record(3014, 100.0)
    found = find_releases(rec.t, rec.y)
    assert len(found) == len(rec.releases) == 2
    assert all(abs(f.release_time_s - r.time_s) <= _tolerance(100.0) for f, r in zip(found, rec.releases))


@pytest.mark.parametrize("seed", [3048, 3007])
def test_a_ringing_cart_caught_and_held_still_where_it_was_caught_is_released(seed: int) -> None:
    """Seed 3048 at 50 Hz: the hand catches the ringing cart at -28 mm, holds it still at -31 mm
    for a second and lets go to a 25 mm swing, less than the swing it caught. Taken for a nudge
    (let go within 3 mm of where it was taken, swinging no more than before), the release was
    lost; a hold let go is a release wherever the hand took the cart. Seed 3007: a nudge of a
    ringing cart at +37 mm (a 2.5 mm bump and back over 0.45 s, the cart still moving by 5 % of
    the swing that follows in the quarter period before the let-go) stays a nudge."""
    rec = student_record(seed, 50.0)
    found = find_releases(rec.t, rec.y)
    assert len(found) == len(rec.releases) == 4
    assert all(abs(f.release_time_s - r.time_s) <= _tolerance(50.0) for f, r in zip(found, rec.releases))


def test_a_clock_whose_first_step_is_short_dates_late_releases_on_its_own_line() -> None:
    """A logger's stamps within 1 % of each other are taken as they are, but the first step
    set the grid: 0.9 % short (a 25 Hz record of a real release, decimated from the 2025
    rig's clock), a release 9 s on was dated 80 ms early. The same records with the first
    stamp moved 0.9 % of a step later: every release where it was."""
    for seed in (21, 24):
        rec = student_record(seed, 50.0)
        t = rec.t.copy()
        t[0] += 0.009 * (t[1] - t[0])
        found = find_releases(t, rec.y)
        assert len(found) == len(rec.releases), (seed, [f.release_time_s for f in found])
        assert all(abs(f.release_time_s - r.time_s) <= _tolerance(50.0) for f, r in zip(found, rec.releases)), \
            (seed, [f.release_time_s for f in found], [r.time_s for r in rec.releases])


def test_a_flat_record_has_no_release() -> None:
    t = np.arange(0.0, 5.0, 0.01)
    y = np.zeros((t.size, 2))
    assert find_releases(t, y) == []


def _csv(path: Path, t: np.ndarray, y: np.ndarray) -> Path:
    rows = "\n".join(",".join(f"{v:.8f}" for v in (ti, *yi)) for ti, yi in zip(t, y, strict=True))
    path.write_text("time_s,pos1_m,pos2_m\n" + rows + "\n")
    return path


def test_diagnose_fits_the_moving_cart_of_a_run_with_a_constant_column(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    # the demo's one-cart runs: cart 1 pinned (reads 0), cart 2 released
    case = make_case(5, "coulomb_friction", carts=1, release="hold")
    t, y = case.observed.t, case.observed.y
    path = _csv(tmp_path / "one_cart.csv", t, np.column_stack([np.zeros(t.size), y[:, 0]]))
    assert main(["diagnose", str(path), "--json", "--figures", str(tmp_path / "fig")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["carts"] == 1 and report["cause"] == "coulomb_friction"
    assert np.isfinite(report["baseline"]["fit_percent"])
    svg = (tmp_path / "fig" / "diagnosis_response.svg").read_text()
    assert "cart 2 position" in svg and "cart 1 position" not in svg


def test_diagnose_never_fits_a_wandering_held_cart_as_free(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    rec = student_record(31, 200.0, 2, both_free=False, start_in_motion=False)
    path = _csv(tmp_path / "held.csv", rec.t, rec.y)
    assert main(["diagnose", str(path), "--all", "--json"]) == 0
    reports = json.loads(capsys.readouterr().out)
    assert len(reports) == len(find_releases(rec.t, rec.y)) >= 1
    assert all(r["carts"] == 1 for r in reports)


@pytest.mark.parametrize("seed", [31, 32])
def test_diagnose_fits_each_release_from_where_ident_releases_dates_it(tmp_path: Path, seed: int,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """`ident diagnose --all` reports each release where `ident releases` lists it and fits from
    a margin (two samples, at least T/200) after the first sample of the diagnosis' evened clock
    at or after it, not from a release of its own: on the 2023 hand steps its own dating had put
    them up to 72 ms later."""
    rec = student_record(seed, 200.0, 2, both_free=False, start_in_motion=False)
    path = _csv(tmp_path / "record.csv", rec.t, rec.y)
    assert main(["releases", str(path), "--json"]) == 0
    listed = [r for r in json.loads(capsys.readouterr().out) if r["complete"]]
    assert main(["diagnose", str(path), "--all", "--json"]) == 0
    reports = {round(r["release_time_s"], 6): r for r in json.loads(capsys.readouterr().out)}
    step = float(np.median(np.diff(rec.t)))
    assert listed
    for release in listed:
        report = min(reports.values(), key=lambda r: abs(r["release_time_s"] - release["release_time_s"]))
        assert abs(report["release_time_s"] - release["release_time_s"]) <= 1e-9, (release, report)
        margin = max(2 * step, release["period_s"] / 200 + step)
        # the first sample at or after the instant is at most a step after it
        assert 0.0 < report["window_start_s"] - report["release_time_s"] <= step + margin + 1e-9, (release, report)
