"""`daq.bus.DaqBus` in one process: a config file, snapshot replies, queued requests answered later."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
import zenoh

from daq.bus import BusRequest, DaqBus, open_session
from daq.errors import DaqIOError
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import DaqCounters, DaqStatus, RunFinished, RunList, ZeroReply


def _status(n_runs: int) -> DaqStatus:
    return DaqStatus(bench="u1", state="idle", run_id=None, port="sim://", dialect="cartlab", connected=True,
                     counts_per_m=20000.0, zero_offsets_raw=[0.0, 0.0], last_t_ns=None, last_pos_m=None,
                     n_runs=n_runs, counters=DaqCounters(), software_version="0")


def test_bus_from_a_config_file_answers_snapshots_and_queued_requests(tmp_path: Path, free_port: int) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port}"
    config_file = tmp_path / "daq.json5"
    config_file.write_text(BusConfig.listener(endpoint).zenoh_json5())
    bus = DaqBus("u1", BusConfig(config_file=str(config_file)))
    client = zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5()))
    try:
        done = RunFinished(bench="u1", run_id="r1", status="complete", file="r1.mcap", n_samples=3,
                           release_time_s=0.5, duration_s=1.0)
        bus.set_snapshot(_status(1), RunList(bench="u1", runs=[done]))
        (status,) = client.get(keys.daq_query("u1", "status"), timeout=5)
        assert status.ok is not None and DaqStatus.from_json_bytes(status.ok.payload.to_bytes()).n_runs == 1
        (finished,) = client.get(keys.run_finished("u1", "r1"), timeout=5)
        assert finished.ok is not None and RunFinished.from_json_bytes(finished.ok.payload.to_bytes()) == done
        assert list(client.get(keys.run_finished("u1", "other"), timeout=2)) == []
        bus.set_snapshot(_status(2))   # a new status alone keeps the run list and finished records
        (status,) = client.get(keys.daq_query("u1", "status"), timeout=5)
        assert status.ok is not None and DaqStatus.from_json_bytes(status.ok.payload.to_bytes()).n_runs == 2
        (runs,) = client.get(keys.daq_query("u1", "runs"), timeout=5)
        assert runs.ok is not None and RunList.from_json_bytes(runs.ok.payload.to_bytes()).runs == [done]
        (finished,) = client.get(keys.run_finished("u1", "r1"), timeout=5)
        assert finished.ok is not None and RunFinished.from_json_bytes(finished.ok.payload.to_bytes()) == done

        def loop_once() -> None:   # stands in for the service loop: answers one queued request
            request: BusRequest = bus.requests.get(timeout=5)
            assert request.kind == "zero"
            bus.reply_record(request, ZeroReply(bench="u1", ok=True, zero_offsets_raw=[1.0, 2.0]))

        server = threading.Thread(target=loop_once)
        server.start()
        (zero,) = client.get(keys.daq_query("u1", "zero"), timeout=5)
        server.join(timeout=5)
        assert zero.ok is not None
        assert ZeroReply.from_json_bytes(zero.ok.payload.to_bytes()).zero_offsets_raw == [1.0, 2.0]
    finally:
        client.close()
        bus.close()


def test_an_endpoint_in_use_is_an_actionable_error(free_port: int) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port}"
    first = open_session(BusConfig.listener(endpoint))
    try:
        with pytest.raises(DaqIOError, match="check that the endpoint is free"):
            open_session(BusConfig.listener(endpoint))
    finally:
        first.close()
