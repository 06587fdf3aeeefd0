import json

import pytest
import zenoh

from schemas import SchemaError
from schemas.bus import BusConfig
from schemas.daq import DaqCounters, GapInterval, RunFinished, RunList, RunMetadata, SampleBatch


def _batch(**over: object) -> SampleBatch:
    fields: dict[str, object] = dict(bench="b1", run_id="r1", batch_seq=3, t_ns=[1, 2], pos1_m=[0.0, 0.1],
                                     pos2_m=[0.0, -0.1], raw1=[0.0, 100.0], raw2=[0.0, -100.0])
    fields.update(over)
    return SampleBatch.model_validate(fields)


def test_sample_batch_round_trips_through_json() -> None:
    batch = _batch()
    again = SampleBatch.from_json_bytes(batch.to_json_bytes())
    assert again == batch
    assert again.pos2_m == [0.0, -0.1]


def test_sample_batch_rejects_ragged_lists() -> None:
    with pytest.raises(SchemaError, match="expected every list of length 2"):
        SampleBatch.from_json_bytes(_batch().to_json_bytes().replace(b"[0.0,0.1]", b"[0.0]"))


def test_sample_batch_needs_both_channel_two_lists() -> None:
    with pytest.raises(ValueError, match="both present or both None"):
        _batch(raw2=None)


def test_run_finished_and_list_round_trip_with_counters() -> None:
    gap = GapInterval(start_t_ns=5, end_t_ns=9, reason="disconnect")
    counters = DaqCounters(lines=10, bad_lines=1, gap_intervals=[gap])
    done = RunFinished(bench="b1", run_id="r1", status="recovered", file="r1.mcap", n_samples=7,
                       release_time_s=0.5, duration_s=1.5, counters=counters)
    listed = RunList.from_json_bytes(RunList(bench="b1", runs=[done]).to_json_bytes())
    assert listed.runs[0].counters.gap_intervals[0].end_t_ns == 9
    assert listed.runs[0].status == "recovered"


def test_run_metadata_schema_is_an_object_schema_with_title() -> None:
    schema = json.loads(RunMetadata.json_schema_bytes())
    assert schema["type"] == "object"
    assert schema["title"] == "RunMetadata"
    assert "release_time_s" in schema["properties"]


def test_bus_config_defaults_are_loopback_without_scouting() -> None:
    conf = zenoh.Config.from_json5(BusConfig().zenoh_json5())
    assert json.loads(conf.get_json("listen/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(conf.get_json("scouting/multicast/enabled")) is False
    assert json.loads(conf.get_json("scouting/gossip/enabled")) is False
    assert BusConfig.connector("tcp/127.0.0.1:9").zenoh_dict()["listen"]["endpoints"] == []


def test_bus_config_rejects_a_malformed_endpoint() -> None:
    with pytest.raises(ValueError, match="expected an endpoint like"):
        BusConfig(connect=["127.0.0.1:7447"])
