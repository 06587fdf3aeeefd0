"""Test support: a one-cart run written as `daq` writes it (MCAP, batched samples, run metadata)."""

from __future__ import annotations

import io
from pathlib import Path


def write_mcap_run(path: Path, t_ns: list[int], pos1: list[float], release_s: float | None) -> None:
    from mcap.writer import Writer

    from schemas import topics
    from schemas.daq import RunMetadata, SampleBatch

    stream = io.BytesIO()
    writer = Writer(stream, chunk_size=4096)
    writer.start(profile=topics.MCAP_PROFILE, library="test")
    schema = writer.register_schema(SampleBatch.schema_name(), "jsonschema", SampleBatch.json_schema_bytes())
    channel = writer.register_channel(topics.SAMPLES, "json", schema)
    for seq, start in enumerate(range(0, len(t_ns), 50)):
        batch = SampleBatch(bench="b", run_id="r1", batch_seq=seq, t_ns=t_ns[start:start + 50],
                            pos1_m=pos1[start:start + 50], raw1=pos1[start:start + 50], raw_unit="m")
        writer.add_message(channel, t_ns[start], batch.to_json_bytes(), t_ns[start])
    meta = RunMetadata(bench="b", run_id="r1", dialect="csv", port="sim://", counts_per_m=1.0, signs=[1],
                       zero_offsets_raw=[0.0], n_channels=1, detector_settings={}, detector_method="x",
                       release_time_s=release_s, release_t_ns=None, first_t_ns=t_ns[0], pre_trigger_s=1.0,
                       pulled_cart=1, software_version="0", started_utc="2026-01-01T00:00:00Z")
    writer.add_metadata(topics.METADATA_RUN, {topics.METADATA_JSON_KEY: meta.to_json_bytes().decode()})
    writer.finish()
    path.write_bytes(stream.getvalue())


def read_run_samples(path: str) -> str:
    """How many samples `schemas.run_file.read_run` reads from `path`, with its expansion check
    off (a file of repeated batches is not a bomb here): a call `testkit.peak_memory` measures."""
    from schemas import run_file

    return str(run_file.read_run(Path(path), run_file.Limits(max_expansion=1e9)).t_ns.size)
