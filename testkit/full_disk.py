"""A disk that fills up, for the full-disk tests and row 5 of `tools/bench_faults.py --issue14`.

`Disk(budget, refusals_until_space)` hands an opener to `daq.service.Service` (its `opener`
seam): the files it opens are real files in a temporary directory, but every write is charged
to a byte budget and refused with ENOSPC past it, as a full file system refuses it. After
`refusals_until_space` refusals (never when None) someone frees space and writes succeed again.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import Any, BinaryIO, cast


class Disk:
    """A disk of `budget` bytes; it refuses (ENOSPC) until `refusals_until_space` refusals were
    made, then space returns."""

    def __init__(self, budget: int, refusals_until_space: int | None) -> None:
        self.budget = budget
        self.refusals = 0
        self.refusals_until_space = refusals_until_space

    def take(self, n: int) -> None:
        if n > self.budget:
            self.refusals += 1
            if self.refusals_until_space is not None and self.refusals >= self.refusals_until_space:
                self.budget = 1 << 40     # someone freed space
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.budget -= n

    def opener(self, path: Path) -> BinaryIO:
        self.take(1)
        return cast(BinaryIO, _OnDisk(open(path, "xb"), self))


class _OnDisk:
    """A file whose writes are charged to the disk's budget first."""

    def __init__(self, handle: BinaryIO, disk: Disk) -> None:
        self._handle, self._disk = handle, disk

    def write(self, data: bytes) -> int:
        self._disk.take(len(data))
        return self._handle.write(data)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)


__all__ = ["Disk"]
