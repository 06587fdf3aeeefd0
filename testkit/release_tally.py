"""Release detection scored against a simulated hand's truth (`tools/bench_releases.py` and
`tests/daq/test_student_releases.py`): stream a finished `sim://` rig, detect, tally."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

from daq.decode import make_decoder
from daq.detector import Released, ReleaseDetector
from daq.frames import DataFrame
from daq.sim.options import parse_sim_url
from daq.sim.rig import Rig


def samples(url: str) -> tuple[Iterator[tuple[float, tuple[float, float]]], list[float]]:
    """(device s, metres) of a finished in-process `sim://` rig, and its true release times."""
    rig = Rig(parse_sim_url(url))
    data = bytearray()
    while not rig.finished:
        rig.produce_bytes(1 << 16)
        data += rig.take(1 << 16)
    scale = rig.options.counts_per_m
    frames = [f for f in make_decoder("cartlab").feed(bytes(data)) if isinstance(f, DataFrame)]
    stream = ((f.t_us * 1e-6, (f.raw[0] / scale, f.raw[1] / scale)) for f in frames)
    return stream, [e.t_s for e in rig.events if e.kind == "release"]


def detect(stream: Iterator[tuple[float, tuple[float, float]]]) -> list[float]:
    """Release instants (device s) `daq.detector.ReleaseDetector` finds in a stream."""
    detector = ReleaseDetector()
    return [e.t_release_s for t, pos in stream for e in detector.feed(t, pos) if isinstance(e, Released)]


@dataclass
class Tally:
    """True releases matched to detected ones within `match_s`; the rest are false runs."""

    releases: int = 0
    recorded: int = 0
    false_runs: int = 0
    errors_s: list[float] = field(default_factory=list)
    misses: list[str] = field(default_factory=list)
    false: list[str] = field(default_factory=list)

    def add(self, truth: list[float], found: list[float], match_s: float, label: str) -> None:
        left = list(found)
        for t_true in truth:
            self.releases += 1
            near = [f for f in left if abs(f - t_true) <= match_s]
            if not near:
                self.misses.append(f"{label} at {t_true:.3f} s")
                continue
            best = min(near, key=lambda f: abs(f - t_true))
            left.remove(best)
            self.recorded += 1
            self.errors_s.append(best - t_true)
        self.false_runs += len(left)
        self.false += [f"{label} at {f:.3f} s" for f in left]
