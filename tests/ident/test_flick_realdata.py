"""Real hand releases: the simple fit and PEM start from the cart's state at the release.

Every complete release `ident.releases` finds in the 2025 team-1 hand records (cart 2 flicked:
let go while it moves) and in the 2023 `DOF1_en2_manual2` hand steps, fitted as `ident fit` and
`ident report` fit it (`ident.fitrun.analyse_fits` on the release's window). Before, every model
was a step from rest: on a flick it moved its release to the first extreme (~57 ms late) and sat
still there while the cart still moved (16-32 mm off at the window's start), and the report's
t_r was that fitted release, not the one the data state.

Checked per window, over the first 0.1 period after the release (where the hand let go):
the model moves with the cart (its travel at least half the measured travel), and it is no
further from the cart there than `START_RMS` times its RMS misfit over the whole free response
(the linear model's misfit is the dry friction it lacks: the start must not be worse than the
rest); the run's release is the data's; each fit % is printed (`-s`).
The records are not in the repository (no licence): the test skips without them.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from ident.data import IdData
from ident.fitrun import FitSettings, RunFileOptions, analyse_fits
from ident.io import load
from ident.releases import releases_of, window_of

M_PER_COUNT_2025 = 1.0 / 56000.0
M_PER_COUNT_2023 = 1.0 / 560 / 100
RECORDS_2025 = ("07-Feb-2025_11_29_09.txt", "07-Feb-2025_11_32_48.txt", "14-Feb-2025_09_22_43.txt",
                "14-Feb-2025_09_44_21.txt")
RECORDS_2023 = tuple(f"DOF1_en2_manual2_test{i}.csv" for i in range(1, 6))
#: The start of the free response looked at: this fraction of a period after the release.
START_PERIODS = 0.1
#: ... where the largest |measured - simulated| stays within this many RMS misfits of the window.
#: The step from rest (last stop) was 7-10 RMS off there on the flicks; from the cart's state at
#: the release 1.8-2.7, and 3.2-3.8 on the 2023 holds, whose hand lets go over ~40 ms.
START_RMS = 5.0


def _windows(realdata: Path) -> Iterator[tuple[str, IdData]]:
    sources = [(realdata / "ECP210_UCSD_2025_team1" / n, RunFileOptions(scale=M_PER_COUNT_2025)) for n in RECORDS_2025]
    sources += [(realdata / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop" / n,
                 RunFileOptions(pos_cols=("Encoder 2",), scale=M_PER_COUNT_2023)) for n in RECORDS_2023]
    for path, options in sources:
        if not path.exists():
            continue
        data = load(path, pos_cols=None if options.pos_cols is None else list(options.pos_cols),
                    scale=options.scale, raw=True)
        for release in releases_of(data):
            if release.complete:
                yield f"{path.stem} @{release.release_time_s:.3f}s", window_of(data, release)


def _start(data: IdData, wn: float) -> np.ndarray:
    release = data.release_time_s
    assert release is not None
    return np.flatnonzero((data.t >= release) & (data.t <= release + START_PERIODS * 2.0 * np.pi / wn))


def test_the_models_move_with_the_cart_from_the_release(realdata_dir: Path) -> None:
    windows = list(_windows(realdata_dir))
    if not windows:
        pytest.skip("none of the 2025 team-1 or 2023 manual2 hand records is present")
    flicks = 0
    for label, window in windows:
        analysis = analyse_fits(window, FitSettings(carts=1))
        assert analysis.release_time_s is not None and analysis.release_time_s == window.release_time_s, label
        assert analysis.pem is not None and analysis.pem_y_hat is not None and len(analysis.simple) == 2, \
            (label, analysis.errors)
        column = analysis.outputs[0] - 1
        data = analysis.data
        near = _start(data, analysis.simple[0].wn_rad_s)
        measured = data.y[near, 0]
        travel = float(np.ptp(measured))
        flicks += travel > 0.005   # a flick moves mm within 0.1 period; a hold barely leaves rest
        fits: list[tuple[str, np.ndarray, float]] = [(s.method, s.y_hat[:, 0], s.fit_percent) for s in analysis.simple]
        fits.append(("pem", analysis.pem_y_hat[:, 0], float(analysis.pem.fit_percent[0])))
        after = data.t >= analysis.release_time_s
        for method, y_hat, percent in fits:
            start_error = float(np.max(np.abs(y_hat[near] - measured)))
            rms = float(np.sqrt(np.mean((y_hat[after] - data.y[after, 0]) ** 2)))
            print(f"{label} (cart column {column + 1}) {method}: fit {percent:.2f} %, start travel "
                  f"{1e3 * travel:.1f} mm, model {1e3 * float(np.ptp(y_hat[near])):.1f} mm, largest error "
                  f"{1e3 * start_error:.1f} mm (RMS misfit {1e3 * rms:.2f} mm)")
            assert np.ptp(y_hat[near]) >= 0.5 * travel, (label, method, "the model sits still while the cart moves")
            assert start_error <= START_RMS * rms, (label, method, "the start misfits more than the rest")
    assert flicks >= 1 or not any("2025" in label for label, _ in windows)
