"""Helpers for the sim/replay/link tests: read a finite port to its end, decode it."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import serial

import daq  # noqa: F401  (registers sim:// and replay://)
from daq.decode import make_decoder
from daq.frames import DataFrame, DecodeCounters, Frame
from daq.serial_handlers import EndOfStream
from daq.sim import Rig, parse_sim_url


def read_all(url: str, max_reads: int = 1_000_000, chunk: int = 65536) -> bytes:
    """Every byte a finite port delivers before EndOfStream (bounded in reads)."""
    port = serial.serial_for_url(url, timeout=0.05)
    out = bytearray()
    try:
        for _ in range(max_reads):
            try:
                out += port.read(max(chunk, port.in_waiting))
            except EndOfStream:
                return bytes(out)
        raise AssertionError(f"{url}: no end of stream after {max_reads} reads")
    finally:
        port.close()


def decode(stream: bytes, dialect: str = "cartlab") -> tuple[list[Frame], DecodeCounters]:
    decoder = make_decoder(dialect)
    return decoder.feed(stream), decoder.counters


def data_frames(frames: list[Frame]) -> list[DataFrame]:
    return [f for f in frames if isinstance(f, DataFrame)]


def run_rig(url: str, max_bytes: int = 50_000_000) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], Rig]:
    """Drive the sim core directly (no port): (t_s (N,), counts (N, carts), rig) of a finite script."""
    rig = Rig(parse_sim_url(url))
    out = bytearray()
    while not rig.finished and len(out) < max_bytes:
        rig.produce_bytes(1 << 16)
        out += rig.take(1 << 20)
    frames = data_frames(decode(bytes(out))[0])
    t_s = np.array([f.t_us for f in frames]) / 1e6
    counts = np.array([f.raw for f in frames])
    return t_s, counts, rig
