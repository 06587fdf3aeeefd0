"""Every release in a raw record: where the hand lets go, the free response after it, which
cart was pulled and which carts move freely (issue 10). Pure numerics: arrays in, a list of
frozen `Release` records out; no files, clocks or printing.

Modules: `record` (the `Release` record), `motion` (grid, period, smoothed derivatives),
`hand` (the force no free cart explains: where a hand acts), `instant` (the release instant
to a sample), `finder` (`find_releases`).
"""

from __future__ import annotations

from ident.releases.finder import find_releases
from ident.releases.record import Release

__all__ = ["Release", "find_releases"]
