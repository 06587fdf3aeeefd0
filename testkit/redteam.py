"""The red team's generators (`tools/redteam`, independent of the package) for the tests that
replay their cases: a module of that folder by name, imported once (its modules import their
siblings by the folder, which is on `sys.path` only while it loads)."""

from __future__ import annotations

import functools
import importlib
import sys
from types import ModuleType

from testkit.repo import REPO

REDTEAM = REPO / "tools" / "redteam"


@functools.cache
def redteam_module(name: str) -> ModuleType:
    """`tools/redteam/<name>.py` (`run11`: both issue-11 generators' cases; `cases10`: the
    issue-10 records)."""
    sys.path.insert(0, str(REDTEAM))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(REDTEAM))


__all__ = ["REDTEAM", "redteam_module"]
