"""MCAP topic and metadata names of cartlab run files, named here and nowhere else.

A run file `<run_id>.mcap` holds:

| what | name | record |
|---|---|---|
| channel | `/samples` | `SampleBatch` messages (log_time = the first sample's UTC time) |
| channel | `/position` | one `PositionSample` message per sample (log_time = its UTC time), for viewers |
| channel | `/state` | `DetectorStateMsg` messages |
| metadata | `cartlab.run_started` | key `json`: the `RunMetadata` known when the run opened |
| metadata | `cartlab.run` | key `json`: the final `RunMetadata` (a crashed `.part` has none) |
| metadata | `cartlab.run_finished` | key `json`: the `RunFinished` record |

One metadata record per name. Readers take `cartlab.run`, else `cartlab.run_started`.
Message `log_time`/`publish_time` are UTC nanoseconds: `t_ns + RunMetadata.utc_offset_ns`
(the device clock `t_ns` stays in every message). `/samples` is the record of the run
(`ident` and exports read it); `/position` repeats every sample as its own message so that a
viewer's time-series plot (Foxglove's Plot panel plots one point per message) shows every
sample on the true time axis.

Schema encoding `jsonschema`, message encoding `json`; schema names `cartlab.<Model>`.
"""

from __future__ import annotations

from typing import Final

SAMPLES: Final = "/samples"
STATE: Final = "/state"
POSITION: Final = "/position"

METADATA_RUN_STARTED: Final = "cartlab.run_started"

METADATA_RUN: Final = "cartlab.run"
METADATA_FINISHED: Final = "cartlab.run_finished"
#: Key, inside each metadata record, of the record's JSON.
METADATA_JSON_KEY: Final = "json"

RUN_SUFFIX: Final = ".mcap"
PART_SUFFIX: Final = ".mcap.part"
MCAP_PROFILE: Final = ""
