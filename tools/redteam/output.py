"""Printing and keeping a red-team run's results (shared by `run10.py` and `run11.py`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def publish(results: list[dict[str, Any]], text: str, out: Path | None) -> None:
    """Print the summary `text`; with `out`, also keep every result (`results.jsonl`) and the
    summary (`summary.md`) there."""
    print(text)
    if out:
        out.mkdir(parents=True, exist_ok=True)
        (out / "results.jsonl").write_text("".join(json.dumps(r, default=float) + "\n" for r in results))
        (out / "summary.md").write_text(text + "\n")
