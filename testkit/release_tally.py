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
from testkit.student_records import instants_in_data

Stream = Iterator[tuple[float, tuple[float, float]]]


@dataclass(frozen=True)
class Record:
    """A finished `sim://` rig: its samples (device s, metres), the true release times, the
    hand's force per unit mass as it let go at each (the jump in the cart's acceleration, m/s²;
    empty unless a `student` drew the record), the readings' noise RMS (m: the Gaussian
    noise and the encoder's count, q²/12) and the pulled cart."""

    stream: Stream
    releases: list[float]
    let_go_m_s2: list[float]
    noise_m: float
    #: the cart a student's hand pulls (the other is held); None for a scripted hand (its case says)
    pulled_cart: int | None = None

    def in_data(self, rate_hz: float, snr: float = 10.0) -> list[bool]:
        """Per release: whether its instant is in the data (`testkit.student_records.instants_in_data`)."""
        return instants_in_data(self.let_go_m_s2, rate_hz, self.noise_m, snr)


def record(url: str) -> Record:
    """Run an in-process `sim://` rig to its end (`Record`)."""
    rig = Rig(parse_sim_url(url))
    data = bytearray()
    while not rig.finished:
        rig.produce_bytes(1 << 16)
        data += rig.take(1 << 16)
    scale = rig.options.counts_per_m
    frames = [f for f in make_decoder("cartlab").feed(bytes(data)) if isinstance(f, DataFrame)]
    stream = ((f.t_us * 1e-6, (f.raw[0] / scale, f.raw[1] / scale)) for f in frames)
    noise = (rig.options.noise_counts ** 2 + 1.0 / 12.0) ** 0.5 / scale
    return Record(stream, [e.t_s for e in rig.events if e.kind == "release"],
                  list(getattr(rig.hand, "let_go_m_s2", [])), noise, getattr(rig.hand, "pulled", None))


def samples(url: str) -> tuple[Stream, list[float]]:
    """(device s, metres) of a finished in-process `sim://` rig, and its true release times."""
    rec = record(url)
    return rec.stream, rec.releases


def detect(stream: Stream) -> list[float]:
    """Release instants (device s) `daq.detector.ReleaseDetector` finds in a stream, up to its
    end (`finish`, as `daq run --until-eof` calls it)."""
    detector = ReleaseDetector()
    found = [e for t, pos in stream for e in detector.feed(t, pos)]
    return [e.t_release_s for e in found + detector.finish() if isinstance(e, Released)]


@dataclass
class Tally:
    """True releases matched to detected ones within `match_s`; the rest are false runs, but
    for those within `match_s` of a catch (a ringing cart a nudge let go away from its rest:
    `testkit.student_records.StudentRecord.catches_s`), counted apart: neither required nor
    false."""

    releases: int = 0
    recorded: int = 0
    false_runs: int = 0
    errors_s: list[float] = field(default_factory=list)
    misses: list[str] = field(default_factory=list)
    false: list[str] = field(default_factory=list)
    #: the releases whose instant is in the data (`Record.in_data`), and their errors when recorded
    in_data: int = 0
    errors_in_data_s: list[float] = field(default_factory=list)
    #: per kind of release (as `add` is told), each release's error (s), None when missed
    by_kind: dict[str, list[float | None]] = field(default_factory=dict)
    catches: int = 0
    at_catches: list[str] = field(default_factory=list)

    def add(self, truth: list[float], found: list[float], match_s: float, label: str,
            in_data: list[bool] | None = None, kinds: list[str] | None = None,
            catches: tuple[float, ...] = ()) -> None:
        left = list(found)
        for k, t_true in enumerate(truth):
            seen = in_data is not None and in_data[k]
            errors = self.by_kind.setdefault(kinds[k], []) if kinds is not None else []
            self.releases += 1
            self.in_data += seen
            near = [f for f in left if abs(f - t_true) <= match_s]
            if not near:
                self.misses.append(f"{label} at {t_true:.3f} s")
                errors.append(None)
                continue
            best = min(near, key=lambda f: abs(f - t_true))
            left.remove(best)
            self.recorded += 1
            self.errors_s.append(best - t_true)
            errors.append(best - t_true)
            if seen:
                self.errors_in_data_s.append(best - t_true)
        self.catches += len(catches)
        caught = [f for f in left if any(abs(f - c) <= match_s for c in catches)]
        left = [f for f in left if f not in caught]
        self.at_catches += [f"{label} at {f:.3f} s" for f in caught]
        self.false_runs += len(left)
        self.false += [f"{label} at {f:.3f} s" for f in left]
