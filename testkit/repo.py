"""The checkout's root: the working directory of the `daq`/`ident` processes tests start.

`testkit` is installed editable with the project, so its parent directory is the checkout.
"""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
