"""What the per-sample `/position` channel costs a run file: bytes on disk and writer time.

1. Size: runs recorded by `daq run` from a `sim://` rig (two encoders, the three lab cases) are
   rewritten without the `/position` channel (same chunk size and compression); prints both
   sizes and the ratio.
2. Writer time: `RunWriter.write_samples` on 200,000 two-channel samples in 20 ms batches
   (1 kHz), CPU time per sample, and the part of it spent on the `/position` messages alone.

    .venv/bin/python tools/bench_run_file.py [--rate-hz 1000] [--samples 200000]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mcap.records import Channel, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from daq.recorder import CHUNK_SIZE, RunWriter, position_json
from schemas import run_file, topics
from testkit.daq_records import run_metadata, sample_batches
from testkit.repo import REPO

SIM = "sim://?realtime=0&rate_hz={rate}&cases=cart1,cart2,both&seed=1&c1=2&c2=2"


def _without_position(path: Path, out: Path) -> None:
    outcome = run_file.ReadOutcome()
    records = list(run_file.iter_records(path, outcome))

    with open(out, "wb") as stream:
        writer = Writer(stream, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        writer.start()
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        for record in records:
            if isinstance(record, Schema) and record.name != "cartlab.PositionSample":
                schema_ids[record.id] = writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel) and record.topic != topics.POSITION:
                channel_ids[record.id] = writer.register_channel(record.topic, record.message_encoding,
                                                                 schema_ids.get(record.schema_id, 0))
            elif isinstance(record, Message) and record.channel_id in channel_ids:
                writer.add_message(channel_ids[record.channel_id], record.log_time, record.data,
                                   record.publish_time, record.sequence)
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
        writer.finish()


def sizes(rate_hz: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        runs = Path(tmp) / "runs"
        subprocess.run([sys.executable, "-m", "daq.cli", "run", "--port", SIM.format(rate=rate_hz), "--runs-dir",
                        str(runs), "--no-zenoh", "--until-eof"], cwd=REPO, check=True, capture_output=True,
                       timeout=300)
        for path in sorted(runs.glob("*.mcap")):
            slim = Path(tmp) / "slim.mcap"
            _without_position(path, slim)
            n = run_file.read_run(path).t_ns.size
            full, without = path.stat().st_size, slim.stat().st_size
            print(f"{path.name}: {n} samples, {full / 1024:.1f} KiB with /position, {without / 1024:.1f} KiB "
                  f"without ({full / without:.2f}x, {(full - without) / n:.1f} B per sample)")


def writer_time(n_samples: int) -> None:
    per_batch = 20
    batches = sample_batches(n_samples // per_batch, per_batch)
    with tempfile.TemporaryDirectory() as tmp:
        writer = RunWriter(Path(tmp), run_metadata(), now_s=0.0)
        start = time.process_time()
        for i, batch in enumerate(batches):
            writer.write_samples(batch, now_s=i * 0.02)
        total = time.process_time() - start
        writer.abandon()
        with open(Path(tmp) / "p.mcap", "wb") as stream:
            sink = Writer(stream, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
            sink.start()
            channel = sink.register_channel(topics.POSITION, "json", 0)
            start = time.process_time()
            seq = 0
            for batch in batches:
                for t, p1, p2 in zip(batch.t_ns, batch.pos1_m, batch.pos2_m or [], strict=True):
                    sink.add_message(channel, t, position_json(t, p1, p2), t, seq)
                    seq += 1
            position = time.process_time() - start
            sink.finish()
    n = per_batch * len(batches)
    print(f"RunWriter.write_samples: {1e6 * total / n:.2f} us per sample ({n} samples), of which the "
          f"/position messages {1e6 * position / n:.2f} us")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rate-hz", type=float, default=1000.0)
    parser.add_argument("--samples", type=int, default=200_000)
    args = parser.parse_args()
    sizes(args.rate_hz)
    writer_time(args.samples)
    return 0


if __name__ == "__main__":
    sys.exit(main())
