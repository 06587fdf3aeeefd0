"""The real hand releases, and what a lab could equally have recorded of them.

Records the project has not seen will be used to check release finding: other sessions of the
same rig, another lab's logger rate, a record started later or stopped sooner, the other cart
pulled. This takes every ECP-210 2025 hand-release record of `../shared/realdata` (nothing is
copied from it) and, besides the record as it is, derives variants that change what a record
looks like and not what the hand did:

- `negated`: both encoders counting the other way (the flick to the other side);
- `swapped`: the encoder columns exchanged (the pulled cart is cart 1, the held one cart 2);
- `offset`: the time base shifted by 1000 s (a clock that did not start at 0);
- `decimated-N`: every N-th sample (the ~890 Hz stream read at ~440, ~180, ~90 and ~45 Hz);
  with `--phases`, from every one of the first N samples (`decimated-N+k`);
- `late-start`: the record starts 0.25 s before the hand begins to push (little quiet time);
- `cut`: the record ends 1.2 s after the first release (the release becomes incomplete).

With `--diagnose`, every complete release `ident releases` finds in each variant is also
diagnosed (`ident.diagnose` on its window, the moving carts chosen by it, as `ident diagnose`
does on a raw record): the whole-window fit %, whether dry friction comes first, and per
release the spread of the fit over the variants (the physics has no time origin, direction or
cart number; a diagnosis that moves with them is chaotic, not physical).

The truth is the independent judge (`testkit.release_judge`, run on the original record) for
every labelled release the variant still holds. Through `daq`'s `ReleaseDetector` (samples fed
in order, as `daq run` does after zeroing) and `ident.releases.find_releases`, it prints per
variant: releases found, extra ones, the largest distance from the judge, the pulled cart; and
in all, how many are within 20 ms of the judge or, on a decimated variant whose sample period
is longer, within one sample period.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python tools/bench_real_variants.py [--only ident|daq] [--diagnose] [--phases]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from daq.detector import Released, ReleaseDetector
from ident.releases import find_releases
from testkit.release_judge import judge_release
from testkit.repo import REPO

Array = npt.NDArray[np.float64]
M_PER_COUNT = 1.0 / 56000.0   # the figure other groups use for this rig (irrelevant to timing)
FOLDER = "ECP210_UCSD_2025_team1"
#: file -> by-eye release times (s) of PROVENANCE.md's table (they only say which is which)
BY_EYE = {
    "07-Feb-2025_11_29_09.txt": (1.7, 8.9),
    "07-Feb-2025_11_32_48.txt": (0.95,),
    "14-Feb-2025_09_22_43.txt": (1.2, 4.8, 9.8),
    "14-Feb-2025_09_44_21.txt": (1.7,),
}
MATCH_S = 0.2   # a found release within this of the judge is that release


@dataclass(frozen=True)
class Variant:
    name: str
    t: Array
    y: Array
    truth: tuple[float, ...]   # judged instants this variant still holds
    pulled: int                # the pulled cart's number


def load(path: Path) -> tuple[Array, Array]:
    rows = np.loadtxt(path, skiprows=1)
    return rows[:, 1].copy(), rows[:, 2:4] * M_PER_COUNT


def variants(t: Array, y: Array, judged: tuple[float, ...], phases: bool = False) -> Iterator[Variant]:
    """The variants of the module docstring; with `phases`, each decimation from every starting
    sample (`decimated-N+k`: a logger's clock falls anywhere against the hand's let-go)."""
    yield Variant("original", t, y, judged, 2)
    yield Variant("negated", t, -y, judged, 2)
    yield Variant("swapped", t, y[:, ::-1].copy(), judged, 1)
    yield Variant("offset", t + 1000.0, y, tuple(j + 1000.0 for j in judged), 2)
    for n in (2, 5, 10, 20):
        for k in range(n if phases else 1):
            yield Variant(f"decimated-{n}" + (f"+{k}" if k else ""), t[k::n].copy(), y[k::n].copy(), judged, 2)
    # the hand begins to push ~0.15-0.25 s before it lets go
    begin = max(0.0, judged[0] - 0.45)
    keep = t >= begin
    yield Variant("late-start", t[keep].copy(), y[keep].copy(), judged, 2)
    keep = t <= judged[0] + 1.2
    yield Variant("cut", t[keep].copy(), y[keep].copy(), judged[:1], 2)


def daq_found(v: Variant) -> list[tuple[float, int]]:
    detector = ReleaseDetector()
    y0 = v.y[0]
    out: list[tuple[float, int]] = []
    for k in range(v.t.size):
        sample = (float(v.y[k, 0] - y0[0]), float(v.y[k, 1] - y0[1]))
        out += [(e.t_release_s, e.channel + 1) for e in detector.feed(float(v.t[k]), sample)
                if isinstance(e, Released)]
    return out


def ident_found(v: Variant) -> list[tuple[float, int]]:
    return [(r.release_time_s, r.pulled_cart) for r in find_releases(v.t, v.y)]


def diagnosed(v: Variant) -> list[tuple[int, float, str]]:
    """(index of the judged release, whole-window fit %, effects) of every complete release."""
    from ident.data import IdData, make_uniform
    from ident.diagnose import diagnose

    out = []
    for r in find_releases(v.t, v.y):
        near = [k for k, j in enumerate(v.truth) if abs(r.release_time_s - j) < MATCH_S]
        if not r.complete or not near:
            continue
        keep = (v.t >= r.release_time_s - 0.25) & (v.t <= r.end_time_s)
        part = make_uniform(IdData(v.t[keep], np.zeros(int(keep.sum())), v.y[keep]), "linear")
        report = diagnose(part.t, part.y, None, start_s=r.release_time_s, stop_s=r.end_time_s,
                          readings=v.y[keep]).report
        out.append((near[0], report.extended.fit_percent, "+".join(e.effect for e in report.effects)))
    return out


def score(v: Variant, found: list[tuple[float, int]]) -> tuple[int, int, float, bool]:
    """(matched, extra, largest |error| s over the matched, every matched pulled cart right)."""
    matched, worst, carts_right = 0, 0.0, True
    used: set[int] = set()
    for truth in v.truth:
        near = [i for i, (when, _) in enumerate(found) if abs(when - truth) < MATCH_S and i not in used]
        if not near:
            continue
        i = min(near, key=lambda i: abs(found[i][0] - truth))
        used.add(i)
        matched += 1
        worst = max(worst, abs(found[i][0] - truth))
        carts_right &= found[i][1] == v.pulled
    return matched, len(found) - len(used), worst, carts_right


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--realdata", type=Path, default=REPO.parent / "shared" / "realdata")
    parser.add_argument("--only", choices=("daq", "ident"), default=None)
    parser.add_argument("--diagnose", action="store_true", help="also diagnose every complete release")
    parser.add_argument("--phases", action="store_true",
                        help="each decimation from every starting sample, not only the first")
    args = parser.parse_args(argv)
    fits: dict[tuple[str, int], list[float]] = {}
    friction_first = diagnoses = 0
    folder = args.realdata / FOLDER
    if not folder.is_dir():
        print(f"no {FOLDER} under {args.realdata}: nothing to measure", file=sys.stderr)
        return 1
    finders: dict[str, Callable[[Variant], list[tuple[float, int]]]] = {"daq": daq_found, "ident": ident_found}
    if args.only:
        finders = {args.only: finders[args.only]}
    totals = {name: [0, 0, 0, 0, 0] for name in finders}   # truth, matched, within 20 ms, extra, cart wrong
    print(f"{'record':26s} {'variant':13s} " + " ".join(f"{n:>32s}" for n in finders))
    for name, eyes in BY_EYE.items():
        t, y = load(folder / name)
        judged = tuple(judge_release(t, y[:, 1], e) for e in eyes)
        for v in variants(t, y, judged, args.phases):
            cells = []
            for fname, finder in finders.items():
                found = finder(v)
                matched, extra, worst, carts = score(v, found)
                tot = totals[fname]
                errs = [min(abs(w - j) for w, _ in found) for j in v.truth if found]
                limit = max(0.020, float(np.median(np.diff(v.t))))
                tot[0] += len(v.truth)
                tot[1] += matched
                tot[2] += sum(e <= limit for e in errs)
                tot[3] += extra
                tot[4] += 0 if carts else 1
                cells.append(f"{matched}/{len(v.truth)} +{extra} worst {1e3 * worst:5.1f} ms"
                             f" {'cart ok' if carts else 'CART X'}")
            print(f"{name:26s} {v.name:13s} " + " ".join(f"{c:>32s}" for c in cells), flush=True)
            for k, fit, effects in diagnosed(v) if args.diagnose else []:
                fits.setdefault((name, k), []).append(fit)
                diagnoses += 1
                friction_first += effects.startswith("coulomb_friction")
                print(f"{'':26s}   release {k + 1}: fit {fit:6.2f} %  {effects}", flush=True)
    for fname, (n, matched, near, extra, wrong) in totals.items():
        print(f"{fname}: found {matched}/{n}, within 20 ms or a sample {near}/{n}, extra {extra}, "
              f"variants with a wrong pulled cart {wrong}")
    if fits:
        every = [f for values in fits.values() for f in values]
        spread = ", ".join(f"{n[:-4]} #{k + 1} {max(v) - min(v):.2f}" for (n, k), v in fits.items())
        print(f"diagnosis: {diagnoses} complete releases, fit >= 97.5 % {sum(f >= 97.5 for f in every)}, "
              f"min {min(every):.2f} %, dry friction first {friction_first}; spread of each release's fit "
              f"over its variants (points): {spread}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
