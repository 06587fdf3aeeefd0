"""MCAP topic and metadata names of cartlab run files, named here and nowhere else.

A run file `<run_id>.mcap` holds:

| what | name | record |
|---|---|---|
| channel | `/samples` | `SampleBatch` messages (log_time = first sample's device `t_ns`) |
| channel | `/state` | `DetectorStateMsg` messages |
| metadata | `cartlab.run` | key `json`: a `RunMetadata` (the last record wins) |
| metadata | `cartlab.run_finished` | key `json`: the `RunFinished` record |

Schema encoding `jsonschema`, message encoding `json`; schema names `cartlab.<Model>`.
"""

from __future__ import annotations

from typing import Final

SAMPLES: Final = "/samples"
STATE: Final = "/state"

METADATA_RUN: Final = "cartlab.run"
METADATA_FINISHED: Final = "cartlab.run_finished"
#: Key, inside each metadata record, of the record's JSON.
METADATA_JSON_KEY: Final = "json"

RUN_SUFFIX: Final = ".mcap"
PART_SUFFIX: Final = ".mcap.part"
MCAP_PROFILE: Final = ""
