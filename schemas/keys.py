"""Every Zenoh key expression of cartlab, built here and nowhere else.

| key | what |
|---|---|
| `cartlab/<bench>/samples` | live samples, batched |
| `cartlab/<bench>/state` | detector state changes |
| `cartlab/<bench>/runs/<run_id>/finished` | run-end record |
| `cartlab/<bench>/runs/<run_id>/fit` | fit report from `ident` |
| `cartlab/<bench>/daq/<query>` | queryables: status, zero, runs, run (MCAP bytes) |
| liveliness `cartlab/<bench>/daq`, `cartlab/ident/<worker>` | who is alive |

Bench names, run ids and worker names are single chunks of `[A-Za-z0-9_.-]`, never `.`
or `..`, so a name can neither widen a key expression nor walk out of a directory.
"""

from __future__ import annotations

import re
from functools import partial
from typing import Annotated, Final, Literal

from pydantic import AfterValidator

from schemas.errors import SchemaError

ROOT: Final = "cartlab"
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}")

DaqQuery = Literal["status", "zero", "arm", "runs", "run"]
DAQ_QUERIES: Final[tuple[DaqQuery, ...]] = ("status", "zero", "arm", "runs", "run")


def check_name(kind: str, name: str) -> str:
    """Return `name` if it is a safe single key chunk and file stem, else raise."""
    if not isinstance(name, str) or not _NAME.fullmatch(name) or name in {".", ".."}:
        raise SchemaError(kind, "1-128 characters of [A-Za-z0-9_.-], not starting with '.' or '-'",
                          repr(name))
    return name


#: Record field types for names that become key chunks or file names: validated on parse.
BenchName = Annotated[str, AfterValidator(partial(check_name, "bench"))]
RunId = Annotated[str, AfterValidator(partial(check_name, "run_id"))]
FileName = Annotated[str, AfterValidator(partial(check_name, "file name"))]


def samples(bench: str) -> str:
    return f"{ROOT}/{check_name('bench', bench)}/samples"


def state(bench: str) -> str:
    return f"{ROOT}/{check_name('bench', bench)}/state"


def run_finished(bench: str, run_id: str) -> str:
    return f"{ROOT}/{check_name('bench', bench)}/runs/{check_name('run_id', run_id)}/finished"


def run_fit(bench: str, run_id: str) -> str:
    return f"{ROOT}/{check_name('bench', bench)}/runs/{check_name('run_id', run_id)}/fit"


def daq_query(bench: str, query: DaqQuery) -> str:
    if query not in DAQ_QUERIES:
        raise SchemaError("daq query", f"one of {', '.join(DAQ_QUERIES)}", repr(query))
    return f"{ROOT}/{check_name('bench', bench)}/daq/{query}"


def daq_queries(bench: str) -> str:
    """Key expression matching every queryable of one bench's daq."""
    return f"{ROOT}/{check_name('bench', bench)}/daq/*"


def daq_alive(bench: str) -> str:
    return f"{ROOT}/{check_name('bench', bench)}/daq"


def ident_alive(worker: str) -> str:
    return f"{ROOT}/ident/{check_name('worker', worker)}"


# Wildcards for subscribers that follow every bench.
ALL_FINISHED: Final = f"{ROOT}/*/runs/*/finished"
ALL_FITS: Final = f"{ROOT}/*/runs/*/fit"
ALL_DAQ_ALIVE: Final = f"{ROOT}/*/daq"
ALL_IDENT_ALIVE: Final = f"{ROOT}/ident/*"


def parse_run_key(key: str) -> tuple[str, str, str]:
    """Split `cartlab/<bench>/runs/<run_id>/<leaf>` into (bench, run_id, leaf)."""
    parts = str(key).split("/")
    if len(parts) != 5 or parts[0] != ROOT or parts[2] != "runs":
        raise SchemaError("run key", f"{ROOT}/<bench>/runs/<run_id>/<leaf>", repr(str(key)))
    return check_name("bench", parts[1]), check_name("run_id", parts[3]), parts[4]


def bench_of(key: str) -> str:
    """The bench chunk of any `cartlab/<bench>/...` key."""
    parts = str(key).split("/")
    if len(parts) < 2 or parts[0] != ROOT:
        raise SchemaError("key", f"{ROOT}/<bench>/...", repr(str(key)))
    return check_name("bench", parts[1])
