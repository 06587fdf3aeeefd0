"""The hand's force around each real let-go, with daq's and the judge's instants (a PNG to look at).

For every release `daq.detector.ReleaseDetector` finds in the ECP-210 2025 hand records of
`../shared/realdata` (nothing is copied from them), the hand's force per unit mass is the free
equation's residual h = x'' + 2ζ wn x' + wn²(x - c) + f·sgn(x') (the judge's fitted free
response, `testkit.release_judge`), with derivatives over 5, 9 and 13 ms; daq's instant and
the judge's are marked, and the force a few ms either side of them printed. This is what
settled which instant is right (docs/daq.md, "Where the hand lets go").

    python tools/plot_hand_force.py --out hand_force.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import numpy.typing as npt

from daq.detector import Released, ReleaseDetector
from testkit.release_judge import even_clock, free_parameters, hand_force, judge_release
from testkit.repo import REPO

Array = npt.NDArray[np.float64]
RECORDS = ("07-Feb-2025_11_29_09.txt", "07-Feb-2025_11_32_48.txt", "14-Feb-2025_09_22_43.txt",
           "14-Feb-2025_09_44_21.txt")
M_PER_COUNT = 1.0 / 56000.0   # the figure other groups use for this rig (irrelevant to timing)
PERIOD_S = 0.405              # the 2025 cart 2's period (wn ≈ 15.5 rad/s)


def load(path: Path) -> tuple[Array, Array]:
    """Time (s) and both encoders (m) of a lab export."""
    rows = np.loadtxt(path, skiprows=1)
    return rows[:, 1], rows[:, 2:4] * M_PER_COUNT


def daq_instants(t: Array, y: Array) -> list[float]:
    detector = ReleaseDetector()
    return [e.t_release_s for k in range(t.size)
            for e in detector.feed(float(t[k]), (float(y[k, 0]), float(y[k, 1]))) if isinstance(e, Released)]


def force_around(t: Array, x: Array, t0: float, window_s: float) -> tuple[Array, Array]:
    """(times s, hand force m/s²) over t0 - 0.3 s .. t0 + 0.85 s, the free response fitted
    from a period's quarter after the extreme (as the judge does)."""
    span = (t >= t0 - 0.3) & (t <= t0 + 0.85)
    te, xs = even_clock(t[span]), x[span]
    top = int(np.argmax(np.abs(xs[: np.searchsorted(te, t0 + 0.15)] - xs[0])))
    q = int(np.searchsorted(te, te[top] + PERIOD_S / 4))
    p = free_parameters(te, xs, q, te.size, PERIOD_S)
    dt = float(np.median(np.diff(te)))
    return te, hand_force(xs, dt, p, max(5, 2 * round(window_s / dt / 2) + 1))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--realdata", type=Path, default=REPO.parent / "shared" / "realdata")
    parser.add_argument("--out", type=Path, default=Path("hand_force.png"))
    args = parser.parse_args(argv)
    folder = args.realdata / "ECP210_UCSD_2025_team1"
    if not folder.is_dir():
        print(f"no real records at {folder}", file=sys.stderr)
        return 2
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cases = []
    for name in RECORDS:
        t, y = load(folder / name)
        cases += [(name, t, y[:, 1], t0) for t0 in daq_instants(t, y)]
    fig, axes = plt.subplots(len(cases), 1, figsize=(9, 3.2 * len(cases)), squeeze=False)
    for ax, (name, t, x, t0) in zip(axes[:, 0], cases, strict=True):
        judged = judge_release(t, x, t0, period_s=PERIOD_S)
        for window_s, style in ((0.005, ":"), (0.009, "-"), (0.013, "--")):
            te, h = force_around(t, x, t0, window_s)
            ax.plot(1e3 * (te - judged), h, style, lw=2, label=f"hand force, {1e3 * window_s:.0f} ms derivatives")
            if window_s == 0.009:
                at = [float(np.interp(judged + d, te, h)) for d in (-0.01, 0.0, 0.01)]
                at_daq = float(np.interp(t0, te, h))
        ax.axvline(0.0, color="k", lw=2, label="judge")
        ax.axvline(1e3 * (t0 - judged), color="r", lw=2, label="daq")
        ax.axhline(0.0, color="gray", lw=1)
        ax.set(xlim=(-150, 100), ylim=(-15, 20), xlabel="time from the judge's instant (ms)",
               ylabel="hand force / mass (m/s²)", title=f"{name}, daq {t0:.4f} s")
        ax.legend(fontsize=7)
        print(f"{name} daq {t0:.4f} s judge {judged:.4f} s (daq - judge {1e3 * (t0 - judged):+.1f} ms); "
              f"force at judge -10/0/+10 ms: {at[0]:+.1f} {at[1]:+.1f} {at[2]:+.1f} m/s², at daq {at_daq:+.1f}")
    fig.tight_layout()
    fig.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
