"""Progress display for the `ident` commands (a thin adapter over `rich.progress`).

A command opens `progress(...)` around its work; while it is open, any code below may call
`advance(label)` (a counted step done) or `stage(label)` (what is running now) without
being passed anything: the active display lives in a context variable, and the calls are
no-ops when no display is open (library use, the worker, tests).

The display goes to stderr, refreshes itself (a spinner and the elapsed time keep moving
through a long step that cannot count its own progress) and is off when stderr is not a
terminal or the user asked for `--quiet`. Never used by the numerical code's results.
"""

from __future__ import annotations

import contextvars
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    SpinnerColumn,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)

_ACTIVE: contextvars.ContextVar[tuple[Progress, TaskID] | None] = contextvars.ContextVar(
    "ident_progress", default=None)


def enabled(quiet: bool, stream: IO[str] | None = None) -> bool:
    """Show progress: not `quiet`, and the stream (default stderr) is a terminal."""
    target = sys.stderr if stream is None else stream
    return not quiet and Console(file=target).is_terminal


@contextmanager
def progress(description: str, total: int | None = None, quiet: bool = False,
             console: Console | None = None) -> Iterator[None]:
    """Show `description` with a bar of `total` steps (None: a spinner only) until the block ends."""
    shown = console if console is not None else Console(file=sys.stderr)
    display = Progress(SpinnerColumn(), TextColumn("[progress.description]{task.description}"),
                       BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                       console=shown, transient=True, disable=quiet or not shown.is_terminal,
                       redirect_stdout=False, redirect_stderr=False)
    with display:
        task = display.add_task(description, total=total)
        token = _ACTIVE.set((display, task))
        try:
            yield
        finally:
            _ACTIVE.reset(token)


def stage(label: str) -> None:
    """Say what runs now (replaces the description's detail)."""
    active = _ACTIVE.get()
    if active is not None:
        display, task = active
        base = display.tasks[task].fields.get("base")
        if base is None:
            base = display.tasks[task].description
            display.update(task, base=base)
        # drawn now, not at the next 10 Hz tick: a stage shorter than a tick is still shown
        display.update(task, description=f"{base}: {label}", refresh=True)


def set_total(total: int) -> None:
    """The number of counted steps, once the work knows it (e.g. the runs of a report)."""
    active = _ACTIVE.get()
    if active is not None:
        display, task = active
        display.update(task, total=total)


def advance(label: str | None = None) -> None:
    """One counted step is done (and, with `label`, what runs next)."""
    active = _ACTIVE.get()
    if active is not None:
        display, task = active
        display.advance(task)
        if label is not None:
            stage(label)
