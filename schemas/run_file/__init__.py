"""The MCAP run file: its layout and the one damage-tolerant reader, with strict limits.

Every reader of run files (`daq` exports and recovery, `ident`'s loader, the worker's and the
page's file lookups) goes through this package; nothing else builds an MCAP reader. Modules:
`layout` (names), `limits` (what a reader accepts), `records` (the record reader),
`contents` (a run as arrays; its `RunFinished`). Import the names from here.

The layout of a runs directory (`.mcap.part`, `.mcap`, `-r<k>.mcap`, `.fit/report.json`,
`quarantine/`) is tabled in `layout`, where every name is built.

Reading (`records.iter_records`): record by record, so a file killed mid-write yields every
complete record and stops at the first damaged one; every size is checked against `limits`
before anything is allocated, and a limit exceeded is a refusal (`RunFileTooLarge`), never a
partial read. `contents.read_run` turns the samples into arrays batch by batch, so memory
stays near the arrays' size.
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
from schemas.run_file.records import ReadOutcome, has_mcap_magic, iter_records

__all__ = ["DAMAGE_ERRORS", "DEFAULT_LIMITS", "FIT_SUFFIX", "PART_SUFFIX", "QUARANTINE_DIR",
           "RECOVERING_SUFFIX", "REPORT_NAME", "RUN_SUFFIX", "Limits", "ReadOutcome",
           "RunContents", "RunFileTooLarge", "final_path", "fit_dir_of", "has_mcap_magic", "iter_records",
           "part_path", "quarantine_path", "read_finished", "read_run", "recovered_run_id",
           "run_file_name", "run_id_of", "run_metadata"]
