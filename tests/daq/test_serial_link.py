"""SerialLink over sim://: chunks, disconnect and reconnect with an injected clock and sleep."""

from __future__ import annotations

import pytest

from daq.decode import make_decoder
from daq.errors import DaqIOError
from daq.frames import DataFrame
from daq.serial_link import LinkEvent, SerialLink
from daq.timeline import Timeline


class FakeTime:
    def __init__(self) -> None:
        self.now = 0.0
        self.sleeps: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


def run_link(url: str, fake: FakeTime, max_reads: int = 100_000) -> tuple[list[DataFrame], list[LinkEvent], SerialLink]:
    link = SerialLink(url, clock=fake.clock, sleep=fake.sleep, backoff_s=0.1, backoff_max_s=0.4)
    link.open()
    decoder = make_decoder("cartlab")
    frames: list[DataFrame] = []
    events: list[LinkEvent] = []
    for _ in range(max_reads):
        got = link.read()
        frames += [f for f in decoder.feed(got.data) if isinstance(f, DataFrame)]
        if got.event is not LinkEvent.DATA:
            events.append(got.event)
        if got.event is LinkEvent.EOF:
            return frames, events, link
    raise AssertionError("no end of stream")


def test_reconnects_after_sim_disconnects_and_counts_the_lost_lines() -> None:
    fake = FakeTime()
    url = ("sim://?realtime=0&cases=none&duration_s=19&rate_hz=100&disconnect_every_s=5"
           "&disconnect_s=1.5&reopen_failures=3")
    frames, events, link = run_link(url, fake)
    cycle = [LinkEvent.DISCONNECTED] + [LinkEvent.DOWN] * 3 + [LinkEvent.RECONNECTED]
    assert events == cycle * 3 + [LinkEvent.EOF]
    assert fake.sleeps == [0.1, 0.2, 0.4, 0.4] * 3       # doubling back-off, capped
    assert link.stats.reconnects == 3 and link.stats.total_gap_s == pytest.approx(3 * 1.1)
    timeline = Timeline()
    for f in frames:
        timeline.push(f.seq, f.t_us)
    # each outage loses the 1.5 s of lines it spans, the seq gaps say so
    assert timeline.counters.seq_gaps == 3
    assert timeline.counters.lost_lines == 3 * 150
    assert len(frames) + timeline.counters.lost_lines == 1901


def test_first_open_failure_is_an_error() -> None:
    link = SerialLink("sim://?bogus=1")
    with pytest.raises(ValueError, match="bogus"):
        link.open()
    with pytest.raises(DaqIOError, match="expected a port that opens"):
        SerialLink("/nonexistent/ttyUSB9").open()


def test_gives_up_after_the_bound() -> None:
    fake = FakeTime()
    link = SerialLink("sim://?realtime=0&cases=none&disconnect_every_s=1&disconnect_s=9&reopen_failures=1000",
                      clock=fake.clock, sleep=fake.sleep, backoff_s=1.0, backoff_max_s=1.0,
                      give_up_after_s=5.0)
    link.open()
    with pytest.raises(DaqIOError, match=r"within 5\.0 s"):
        for _ in range(10_000):
            link.read()
    link.close()
