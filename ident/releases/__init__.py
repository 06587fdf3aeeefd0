"""Every release in a raw record: where the hand lets go, the free response after it, which
cart was pulled and which carts move freely (issue 10). Pure numerics: arrays in, a list of
frozen `Release` records out; no files, clocks or printing.

Modules: `record` (the `Release` record), `motion` (grid, period, smoothed derivatives),
`hand` (the force no free cart explains: where a hand acts), `judge` (whether a hand episode
lets a cart go), `instant` (the release instant between samples), `finder`
(`find_releases`), `select` (release K of a loaded record, the record cut to its free
response, and a whole record with its step at the release found).
This is ident's one release estimator: the loaders place the step of a record whose release
time is not known where it finds the first complete release.
"""

from __future__ import annotations

from ident.releases.finder import find_releases
from ident.releases.record import Release
from ident.releases.select import (
    FIRST_COMPLETE,
    choose,
    moving_columns,
    releases_of,
    select_or_whole,
    select_release,
    window_of,
    with_found_release,
)

__all__ = ["FIRST_COMPLETE", "Release", "choose", "find_releases", "moving_columns", "releases_of",
           "select_or_whole", "select_release", "window_of", "with_found_release"]
