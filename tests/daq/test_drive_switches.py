"""`daq.drive.DriveSwitches`: which switches of the rig's drive make a run the drive's, and when."""

from __future__ import annotations

from daq.drive import LEAD_NS, RECENT_NS, DriveSwitches

MS = 1_000_000


def _fed(drives: list[tuple[int, tuple[float, float] | None]]) -> DriveSwitches:
    switches = DriveSwitches()
    for t_ns, drive in drives:
        switches.push(t_ns, drive)
    return switches


def test_a_step_of_a_steady_drive_redates_a_release_near_it_to_the_switch() -> None:
    switches = _fed([(k * MS, (0.0, 0.0) if k < 5000 else (491.0, 0.12)) for k in range(6000)])
    assert switches.at_release(5008 * MS) == (True, 5000 * MS)      # dated 8 ms after
    assert switches.at_release(4999 * MS) == (True, 5000 * MS)      # 1 ms before
    assert switches.at_release(5000 * MS + LEAD_NS + MS) == (False, 5000 * MS + LEAD_NS + MS)
    assert switches.recent(5000 * MS + RECENT_NS + MS) is None
    fresh = _fed([(k * MS, (0.0, 0.0) if k < 5000 else (491.0, 0.12)) for k in range(6000)])
    assert fresh.recent(5223 * MS) == 5000 * MS
    fresh.at_release(5008 * MS)
    assert fresh.recent(5223 * MS) is None   # already a run's release


def test_a_drive_that_changes_at_every_sample_marks_the_run_but_keeps_its_date() -> None:
    switches = _fed([(k * MS, (0.0, 0.1 * (k % 7))) for k in range(3000)])
    assert switches.at_release(2500 * MS) == (True, 2500 * MS)
    assert switches.recent(2900 * MS) is None


def test_a_stream_without_a_drive_or_with_one_at_rest_has_no_switch() -> None:
    assert _fed([(k * MS, None) for k in range(3000)]).at_release(2000 * MS) == (False, 2000 * MS)
    assert _fed([(k * MS, (0.0, 0.0)) for k in range(3000)]).recent(2000 * MS) is None
