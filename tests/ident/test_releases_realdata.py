"""`ident releases` on the real hand-release records (shared/realdata, skipped when absent).

ECP-210 2025 (UCSD team 1): the releases of the PROVENANCE table, found from the raw files,
none from the nudge or the later cart-1 moves, the ones cut by the end of the record
flagged. Each release instant is checked against an independent judge (`testkit/release_judge.py`:
a nonlinear free-response fit and a change-point fit of where the hand's force, the free
equation's residual, ends) to within 20 ms. The
by-eye times of the table (± 0.1 s) only say which release is which. Counts to metres at
56,000 counts/m (the figure other groups use; unverified, and irrelevant to timing).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from ident.cli import main
from testkit.release_judge import judge_release

M_PER_COUNT = 1.0 / 56000.0
FOLDER_2025 = "ECP210_UCSD_2025_team1"
#: file -> [(by-eye release time s, cut by the end of the record)], from PROVENANCE.md
HAND_RELEASES = {
    "07-Feb-2025_11_29_09.txt": [(1.7, False), (8.9, True)],
    "07-Feb-2025_11_32_48.txt": [(0.95, False)],   # "≈ 0.5–1.05": flicked to -5,300 at ≈ 1.0 s
    "14-Feb-2025_09_22_43.txt": [(1.2, False), (4.8, False), (9.8, True)],
    "14-Feb-2025_09_44_21.txt": [(1.7, False)],    # a nudge at 0.9 s and a cart-1 move at 6.5 s
}


def _releases(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> list[dict[str, object]]:
    assert main(["releases", str(path), "--scale", repr(M_PER_COUNT), "--json", *extra]) == 0
    out: list[dict[str, object]] = json.loads(capsys.readouterr().out)
    return out


def _raw(path: Path) -> tuple[np.ndarray, np.ndarray]:
    rows = np.loadtxt(path, skiprows=1)
    return rows[:, 1], rows[:, 2:4] * M_PER_COUNT


@pytest.mark.parametrize("name", sorted(HAND_RELEASES))
def test_every_labelled_hand_release_is_found_once_and_timed(realdata_dir: Path, name: str,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    path = realdata_dir / FOLDER_2025 / name
    if not path.exists():
        pytest.skip(f"{name} not in the real-data folder")
    found = _releases(path, capsys)
    labels = HAND_RELEASES[name]
    assert len(found) == len(labels), found
    t, _ = _raw(path)
    for release, (by_eye, cut) in zip(found, labels, strict=True):
        when = float(release["release_time_s"])   # type: ignore[arg-type]
        assert abs(when - by_eye) < 0.2, (when, by_eye)
        assert release["pulled_cart"] == 2 and release["moving_carts"] == [2]
        assert release["complete"] is (not cut)
        assert when < float(release["end_time_s"]) <= t[-1]   # type: ignore[arg-type]
    # each free response stops before the next release's hand moves the cart
    for before, after in itertools.pairwise(found):
        assert float(before["end_time_s"]) < float(after["release_time_s"]) - 0.1   # type: ignore[arg-type]


@pytest.mark.parametrize("name", sorted(HAND_RELEASES))
def test_every_labelled_hand_release_is_within_20_ms_of_the_judge(realdata_dir: Path, name: str,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    path = realdata_dir / FOLDER_2025 / name
    if not path.exists():
        pytest.skip(f"{name} not in the real-data folder")
    found = _releases(path, capsys)
    t, y = _raw(path)
    for release, (by_eye, _) in zip(found, HAND_RELEASES[name], strict=True):
        when = float(release["release_time_s"])   # type: ignore[arg-type]
        judged = judge_release(t, y[:, 1], by_eye)
        print(f"{name}: release {when:.3f} s, judged {judged:.3f} s, by eye {by_eye} s")
        assert abs(when - judged) <= 0.020


def test_later_cart_1_moves_end_the_free_response(realdata_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # cart 1 is moved by hand from ≈ 6.1 s (it pulls cart 2 through the spring): not a
    # release, and the window of the release before it stops before cart 2 is moved
    path = realdata_dir / FOLDER_2025 / "14-Feb-2025_09_44_21.txt"
    if not path.exists():
        pytest.skip("14-Feb-2025_09_44_21.txt not in the real-data folder")
    (release,) = _releases(path, capsys)
    t, y = _raw(path)
    cart2 = y[:, 1]
    moved = t[(t > 5.5) & (np.abs(cart2 - np.median(cart2[(t > 5.0) & (t < 6.0)])) > 20 * M_PER_COUNT)]
    assert release["ended_by"] == "touch"
    assert float(release["end_time_s"]) <= moved[0]   # type: ignore[arg-type]


@pytest.mark.parametrize("test", range(1, 6))
def test_the_2023_hand_steps_are_one_complete_release_each(realdata_dir: Path, test: int,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    path = realdata_dir / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop" / f"DOF1_en2_manual2_test{test}.csv"
    if not path.exists():
        pytest.skip(f"{path.name} not in the real-data folder")
    (release,) = _releases(path, capsys, "--pos", "Encoder 2")
    rows = np.loadtxt(path, skiprows=2, converters=None, comments=None, usecols=(1, 3),
                      delimiter=None, dtype=str)
    t = np.array([float(v.strip("[;]")) for v in rows[:, 0]])
    x = np.array([float(v.strip("[;]")) for v in rows[:, 1]])
    # the hand step: from where encoder 2 leaves its rest to its first peak
    rest = np.median(x[:20])
    leaves = t[np.flatnonzero(np.abs(x - rest) > 0.05 * np.ptp(x))[0]]
    peak = t[int(np.argmax(np.abs(x - rest)))]
    when = float(release["release_time_s"])   # type: ignore[arg-type]
    assert leaves - 0.05 <= when < peak
    assert release["pulled_cart"] == 2 and release["moving_carts"] == [2]
    assert release["complete"] is True


#: Records driven by the motor (open-loop voltage pulses on cart 1, closed-loop steps): no
#: hand lets a cart go in them. One of each kind (folder, file).
MOTOR_RECORDS = [
    (FOLDER_2025, "07-Feb-2025_11_16_25.txt"),                          # cart 2 held, 0.6 V pulse
    (FOLDER_2025, "07-Feb-2025_11_21_31.txt"),                          # both carts free, 0.6 V pulse
    ("ECP210_UCSD_2023_Parker-Knopf/Closed_Loop", "closed_loop_pid.csv"),
    ("ECP210_UCSD_2023_Parker-Knopf/Open_Loop", "DOF1_en1_input1_test1.csv"),
    ("ECP210_UCSD_2023_Parker-Knopf/Open_Loop", "DOF2_en12_input1_test1.csv"),
]


@pytest.mark.parametrize(("folder", "name"), MOTOR_RECORDS)
def test_motor_driven_records_have_no_release(realdata_dir: Path, folder: str, name: str,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    # the end of a voltage pulse lets the cart ring, but a steady force held it while it
    # swung: a step response, not a hand letting go
    path = realdata_dir / folder / name
    if not path.exists():
        pytest.skip(f"{name} not in the real-data folder")
    assert _releases(path, capsys) == []
