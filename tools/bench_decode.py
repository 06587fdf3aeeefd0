"""Benchmark of the serial side: decoder lines/s per dialect (clean and 1 % corrupted), the
simulated rig's output rate at `realtime=0`, and the CPU share of reading a real-time
1 kHz sim through `SerialLink` and decoding it.

    .venv/bin/python tools/bench_decode.py [--lines 200000] [--chunk 4096]

Prints one line per figure; best of 3 runs. Streams come from `sim://` (two encoders,
1 kHz, the default script), so the line lengths are those of the real dialects.
"""

from __future__ import annotations

import argparse
import time

import serial

import daq  # noqa: F401  (registers sim://)
from daq.decode import make_decoder
from daq.serial_handlers import EndOfStream
from daq.serial_link import SerialLink


def sim_stream(url: str, n_bytes: int) -> tuple[bytes, float]:
    """(bytes, seconds) of reading `n_bytes` from a realtime=0 sim port."""
    port = serial.serial_for_url(url)
    out = bytearray()
    start = time.perf_counter()
    try:
        while len(out) < n_bytes:
            out += port.read(65536)
    except EndOfStream:
        pass
    finally:
        port.close()
    return bytes(out), time.perf_counter() - start


def decode_rate(dialect: str, stream: bytes, chunk: int) -> tuple[float, int]:
    """(lines/s, frames) for feeding `stream` in `chunk`-byte pieces; best of 3."""
    best = float("inf")
    frames = 0
    lines = stream.count(b"\n")
    for _ in range(3):
        decoder = make_decoder(dialect)
        start = time.perf_counter()
        frames = 0
        for i in range(0, len(stream), chunk):
            frames += len(decoder.feed(stream[i:i + chunk]))
        best = min(best, time.perf_counter() - start)
    return lines / best, frames


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=200_000, help="lines per stream")
    parser.add_argument("--chunk", type=int, default=4096, help="bytes per feed() call")
    parser.add_argument("--realtime-s", type=float, default=3.0, help="seconds of the real-time CPU figure (0: skip)")
    args = parser.parse_args(argv)
    base = "sim://?realtime=0&rate_hz=1000&cases=cart1,cart2,both&repeat=100&seed=1"
    for dialect, line_bytes in (("cartlab", 30), ("csv", 30), ("ecp", 30)):
        for label, extra in (("clean", ""), ("1% corrupted", "&corrupt=0.01")):
            stream, _ = sim_stream(f"{base}&dialect={dialect}{extra}", args.lines * line_bytes)
            rate, frames = decode_rate(dialect, stream, args.chunk)
            print(f"decode {dialect:8s} {label:13s}: {rate:12,.0f} lines/s "
                  f"({frames} frames, {len(stream):,} B, chunk {args.chunk} B)")
    stream, seconds = sim_stream(base, 3_000_000)
    lines = stream.count(b"\n")
    print(f"sim realtime=0 1 kHz two carts : {len(stream) / seconds:12,.0f} B/s, "
          f"{lines / seconds:,.0f} lines/s ({lines / 1000 / seconds:.0f}x real time)")
    if args.realtime_s > 0:
        share, frames = realtime_cpu("sim://?rate_hz=1000&cases=cart1&rest_s=0.2&pull_s=0.5&hold_s=0.5",
                                     args.realtime_s)
        print(f"sim realtime=1 1 kHz via SerialLink + decoder: {100 * share:.1f} % of a core "
              f"({frames} frames in {args.realtime_s:g} s, rig and reader in one process)")
    return 0


def realtime_cpu(url: str, seconds: float) -> tuple[float, int]:
    """(CPU share, frames) of reading and decoding a real-time sim through SerialLink."""
    link = SerialLink(url)
    link.open()
    decoder = make_decoder("cartlab")
    frames = 0
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        while time.perf_counter() - wall < seconds:
            frames += len(decoder.feed(link.read().data))
    finally:
        link.close()
    return (time.process_time() - cpu) / (time.perf_counter() - wall), frames


if __name__ == "__main__":
    raise SystemExit(main())
