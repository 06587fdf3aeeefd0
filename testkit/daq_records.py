"""Run records as `daq` writes them, for recorder and run-file tests: metadata and sample batches."""

from __future__ import annotations

import numpy as np

from daq.recorder import utc_now_iso
from schemas.daq import RunMetadata, SampleBatch


def run_metadata(run_id: str = "r1", first_t_ns: int = 1_000_000_000,
                 release_t_ns: int | None = 1_500_000_000) -> RunMetadata:
    """Metadata of a two-channel run `run_id` of bench `b1` (20000 counts/m, zero offsets 10 and 20)."""
    return RunMetadata(bench="b1", run_id=run_id, dialect="cartlab", port="sim://", counts_per_m=20000.0,
                       signs=[1, -1], zero_offsets_raw=[10.0, 20.0], n_channels=2,
                       detector_settings={"fire_m": 0.003}, detector_method="test",
                       release_time_s=None if release_t_ns is None else (release_t_ns - first_t_ns) / 1e9,
                       release_t_ns=release_t_ns, first_t_ns=first_t_ns, pre_trigger_s=0.5,
                       software_version="0.1.0", started_utc=utc_now_iso())


def sample_batches(n_batches: int, per_batch: int = 20, rng_seed: int = 1) -> list[SampleBatch]:
    """`n_batches` seeded batches of random counts at 1 kHz from t = 1 s (bench `b1`, run `r1`)."""
    rng = np.random.default_rng(rng_seed)
    out = []
    for b in range(n_batches):
        t = [1_000_000_000 + (b * per_batch + i) * 1_000_000 for i in range(per_batch)]
        raw1 = rng.integers(-3000, 3000, per_batch).astype(float).tolist()
        raw2 = rng.integers(-3000, 3000, per_batch).astype(float).tolist()
        out.append(SampleBatch(bench="b1", run_id="r1", batch_seq=b, t_ns=t, raw1=raw1, raw2=raw2,
                               pos1_m=[(r - 10) / 20000 for r in raw1], pos2_m=[-(r - 20) / 20000 for r in raw2]))
    return out
