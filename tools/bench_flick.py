"""Simple fit and PEM on real hand releases: released from rest vs. the initial state estimated.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python tools/bench_flick.py [--realdata ../shared/realdata]
        [--records NAME ...]

Every complete release `ident.releases` finds in the 2025 team-1 hand records (cart 2 flicked,
cart 1 held) and in the 2023 `DOF1_en2_manual2` hand steps (encoder 2), cut as `ident fit`
cuts it (`ident.releases.window_of`, the moving cart on a uniform grid). Per release and per
fit (`fit_simple` RK4, Euler, Euler with dry friction; `pem` order 2) it prints fit % with the
cart released from rest ("rest"/"zero": the model of the last stop) and with
`initial_state="auto"` (the new default), which start was kept, the velocity at the release,
and the largest |measured - simulated| (mm) over the window's first 0.1 period: a model that
sits still while the cart moves shows there. The records are not in the repository (no
licence): pass their folder.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ident import pem
from ident.data import IdData
from ident.errors import IdentError
from ident.fitrun import RunFileOptions
from ident.fitrun.analysis import case_samples
from ident.io import load
from ident.releases import releases_of, window_of
from ident.simple import fit_simple

M_PER_COUNT_2025 = 1.0 / 56000.0
M_PER_COUNT_2023 = 1.0 / 560 / 100
RECORDS_2025 = ("07-Feb-2025_11_29_09.txt", "07-Feb-2025_11_32_48.txt", "14-Feb-2025_09_22_43.txt",
                "14-Feb-2025_09_44_21.txt")
RECORDS_2023 = tuple(f"DOF1_en2_manual2_test{i}.csv" for i in range(1, 6))


def windows(realdata: Path, names: set[str] | None) -> Iterator[tuple[str, IdData]]:
    """(label, the pulled cart's window) for every complete release of the records."""
    sources = [(realdata / "ECP210_UCSD_2025_team1" / n, RunFileOptions(scale=M_PER_COUNT_2025)) for n in RECORDS_2025]
    sources += [(realdata / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop" / n,
                 RunFileOptions(pos_cols=("Encoder 2",), scale=M_PER_COUNT_2023)) for n in RECORDS_2023]
    for path, options in sources:
        if not path.exists() or (names and path.name not in names):
            continue
        data = load(path, pos_cols=None if options.pos_cols is None else list(options.pos_cols),
                    scale=options.scale, raw=True)
        for release in releases_of(data):
            if not release.complete:
                continue
            cut = window_of(data, release)
            numbers = cut.cart_numbers()
            column = numbers.index(release.pulled_cart) + 1 if release.pulled_cart in numbers else 1
            yield f"{path.stem} @{release.release_time_s:.3f}s", case_samples(cut, (column,))


def start_error_mm(data: IdData, y_hat: np.ndarray, wn: float) -> float:
    """max |y - ŷ| (mm) over the samples within 0.1 period after the release."""
    release = data.release_time_s if data.release_time_s is not None else float(data.t[0])
    near = (data.t >= release) & (data.t <= release + 0.1 * 2.0 * np.pi / wn)
    return 1e3 * float(np.max(np.abs(data.y[near, 0] - y_hat[near, 0])))


def row(label: str, data: IdData) -> list[str]:
    cells = []
    for name, fit in (("rk4", lambda s: fit_simple(data, "rk4", initial_state=s)),
                      ("euler", lambda s: fit_simple(data, "euler", initial_state=s)),
                      ("euler+f", lambda s: fit_simple(data, "euler", friction=True, initial_state=s))):
        parts, kept, v0 = [], "", 0.0
        for state in ("rest", "auto"):
            try:
                f = fit(state)
                parts.append(f"{f.fit_percent[0]:6.2f} ({start_error_mm(data, f.y_hat, f.wn):5.1f})")
                kept, v0 = f.initial_state, f.release_velocity
            except IdentError as exc:
                parts.append(f"failed: {str(exc)[:30]}")
        cells.append(f"{name} {parts[0]} -> {parts[1]} [{kept} {v0:+.3f} m/s]")
    kept_pem = ""
    parts = []
    for state in ("zero", "auto"):
        try:
            m = pem(data, 2, initial_state=state)   # type: ignore[arg-type]
            y_hat = m.simulate(data.u)
            parts.append(f"{m.fit_percent[0]:6.2f} ({start_error_mm(data, y_hat, m.modes[0].wn):5.1f})")
            kept_pem = "estimate" if m.initial_velocity is not None else "zero"
        except IdentError as exc:
            parts.append(f"failed: {str(exc)[:30]}")
    cells.append(f"pem2 {parts[0]} -> {parts[1]} [{kept_pem}]")
    return [label, *cells]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realdata", type=Path, default=Path("../shared/realdata"))
    parser.add_argument("--records", nargs="*", default=None, help="file names to keep (default: all)")
    args = parser.parse_args()
    print("fit % from rest -> auto (max |error| mm over the first 0.1 period) [start kept, v0]")
    began = time.perf_counter()
    for label, data in windows(args.realdata, set(args.records) if args.records else None):
        cells = row(label, data)
        print(cells[0])
        for cell in cells[1:]:
            print("   ", cell)
    print(f"({time.perf_counter() - began:.1f} s)")


if __name__ == "__main__":
    main()
