"""The MCAP run file: its layout and the one damage-tolerant reader, with strict limits.

Every reader of run files (`daq` exports and recovery, `ident`'s loader, the worker's and the
page's file lookups) goes through this package; nothing else builds an MCAP reader. Modules:
`layout` (names), `limits` (what a reader accepts), `records` (the record reader),
`contents` (a run as arrays; its `RunFinished`). Import the names from here.

Layout of a runs directory (names built in `layout` and nowhere else):

| file | what |
|---|---|
| `<run_id>.mcap.part` | a run being written (or left by a crash) |
| `<run_id>.mcap` | a finished run: never overwritten, never deleted |
| `<run_id>-r<k>.mcap` | data recovered from a `.part` whose finished name was taken |
| `<run_id>.fit/report.json` | the fit report (and figures) beside the run file |
| `quarantine/<name>` | a `.part` nothing could be read from, moved aside (never deleted) |

Reading (`iter_records`): `mcap`'s sequential reader walks the file record by record, so a
file killed mid-write (no summary, an unfinished chunk) yields every complete record and
stops at the first damaged one (`ReadOutcome.complete` is then False). Chunks are opened
here, not by `mcap`, so that every size is checked before anything is allocated:

    file bytes ≤ max_file_bytes, each record ≤ max_record_bytes,
    each chunk's decompressed size ≤ max_record_bytes and (past 1 MiB) ≤ max_expansion × its
    compressed size, all chunks ≤ max_decompressed_bytes, messages ≤ max_messages,
    samples ≤ max_samples.

A limit exceeded is a refusal (`RunFileTooLarge`), never a partial read: a bomb is not data.
Samples are turned into arrays batch by batch, so memory stays near the arrays' size
(8 bytes per value), well under the file's decompressed JSON.
"""

from schemas.run_file.contents import RunContents, read_finished, read_run, run_metadata
from schemas.run_file.layout import (
    FIT_SUFFIX,
    PART_SUFFIX,
    QUARANTINE_DIR,
    RECOVERING_SUFFIX,
    REPORT_NAME,
    RUN_SUFFIX,
    final_path,
    fit_dir_of,
    part_path,
    quarantine_path,
    recovered_run_id,
    run_file_name,
    run_id_of,
)
from schemas.run_file.limits import DAMAGE_ERRORS, DEFAULT_LIMITS, Limits, RunFileTooLarge
from schemas.run_file.records import ReadOutcome, iter_records

__all__ = ["DAMAGE_ERRORS", "DEFAULT_LIMITS", "FIT_SUFFIX", "PART_SUFFIX", "QUARANTINE_DIR",
           "RECOVERING_SUFFIX", "REPORT_NAME", "RUN_SUFFIX", "Limits", "ReadOutcome",
           "RunContents", "RunFileTooLarge", "final_path", "fit_dir_of", "iter_records",
           "part_path", "quarantine_path", "read_finished", "read_run", "recovered_run_id",
           "run_file_name", "run_id_of", "run_metadata"]
