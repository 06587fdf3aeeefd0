"""The one bounded wait of the tests and tools: until a condition holds or an event is set.

Nothing sleeps "to let things happen": a wait names what it waits for, gives up after
`timeout_s` with `TimeoutError`, and fails early with `ProcessDied` when a process it
watches exits. Between checks it waits on a `threading.Event` (the awaited one, if it was
given one), so it returns as soon as that event is set.
"""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any, Protocol, TypeVar, overload

T = TypeVar("T")


class ProcessDied(RuntimeError):
    """A process a wait depended on exited before the awaited thing happened."""


class Watched(Protocol):
    """A process handle that raises `ProcessDied` (with its log's tail) once it has exited."""

    def check_alive(self) -> None: ...


Watchable = subprocess.Popen[Any] | Watched


def check_running(proc: Watchable, what: str) -> None:
    """Raise `ProcessDied` if `proc` has exited (a `Popen`, or a handle with `check_alive`)."""
    if not isinstance(proc, subprocess.Popen):
        proc.check_alive()
        return
    code = proc.poll()
    if code is not None:
        raise ProcessDied(f"{what}: the process {proc.args!r} exited with code {code}")


def _as_list(watch: Watchable | Iterable[Watchable]) -> list[Watchable]:
    if isinstance(watch, subprocess.Popen) or not isinstance(watch, Iterable):
        return [watch]
    return list(watch)


@overload
def wait_until(condition: threading.Event, timeout_s: float, what: str,
               watch: Watchable | Iterable[Watchable] = (), *,
               progress: Callable[[], None] | None = None, poll_s: float = 0.02) -> bool: ...


@overload
def wait_until(condition: Callable[[], T], timeout_s: float, what: str,
               watch: Watchable | Iterable[Watchable] = (), *,
               progress: Callable[[], None] | None = None, poll_s: float = 0.02) -> T: ...


def wait_until(condition: Callable[[], T] | threading.Event, timeout_s: float, what: str,
               watch: Watchable | Iterable[Watchable] = (), *,
               progress: Callable[[], None] | None = None, poll_s: float = 0.02) -> T | bool:
    """The first truthy value of `condition()` (`True` once the event is set).

    Checks every `poll_s` seconds (an awaited event ends the pause at once); calls
    `progress()` between checks; raises `ProcessDied` as soon as a watched process (one, or
    several) has exited and `TimeoutError` naming `what` after `timeout_s` seconds.
    """
    deadline = time.monotonic() + timeout_s
    check: Callable[[], T | bool]
    if isinstance(condition, threading.Event):
        pause, check = condition, condition.is_set
    else:
        pause, check = threading.Event(), condition
    watched = _as_list(watch)
    while True:
        value = check()
        if value:
            return value
        for proc in watched:
            check_running(proc, what)
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError(f"timed out after {timeout_s:g} s waiting for {what}")
        if progress is not None:
            progress()
        pause.wait(min(poll_s, left))
