"""A release of a loaded record, and the record cut to its free response.

`choose(releases, number)`: release K (1-based), or with `FIRST_COMPLETE` the first release
the record does not cut (else the first); `window_of(data, release)`: the record from the
release instant to the end of its free response, with the release step at that instant;
`select_release(data, number)`: both, as `ident.fitrun`'s release selector;
`with_found_release(t, y)`: a whole record with its release step where the finder puts the
first complete release (the loaders' choice for a record whose release time is not known).
No file I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from ident.data import IdData, check_arrays, from_release
from ident.errors import IdentValueError
from ident.release import check_motion
from ident.releases.finder import find_releases
from ident.releases.record import HELD_FRACTION, Release

#: `number` meaning "the first complete release" (the default of `ident fit` and `diagnose`).
FIRST_COMPLETE = 0
#: Default pull distance of the lab (m): the cart is held 0.15 m from rest (the step of a
#: release whose own pull cannot be told, `release_step`).
DEFAULT_STEP_M = 0.15
#: Fewest samples a window keeps (the fitters' minimum is 20).
MIN_WINDOW_SAMPLES = 50


def choose(releases: Sequence[Release], number: int) -> Release:
    """Release `number` (1-based) or, for `FIRST_COMPLETE`, the first complete one."""
    if not releases:
        raise IdentValueError("release", "a record with a release (a free response after a hand "
                              "let a cart go; see `ident releases`)", "none found")
    if number == FIRST_COMPLETE:
        return next((r for r in releases if r.complete), releases[0])
    if not 1 <= number <= len(releases):
        raise IdentValueError("release", f"a number from 1 to {len(releases)} (see `ident releases`)",
                              number)
    return releases[number - 1]


def window_of(data: IdData, release: Release, step_m: float | None = None) -> IdData:
    """`data` from the sample before the release to the end of its free response (at least
    `MIN_WINDOW_SAMPLES` samples), the input a step at the release, the pulled cart known.

    The step is `step_m` (m) when given, else the record's own (a daq run's pull), else the
    release's (`release_step`): signed, so that a cart let go on either side of its rest
    has a positive gain (a flick to the negative side is no loss)."""
    # one sample before the release: the fitters see the step happen inside the window
    start = max(0, int(np.searchsorted(data.t, release.release_time_s, side="left")) - 1)
    stop = int(np.searchsorted(data.t, release.end_time_s, side="right"))
    stop = min(max(stop, start + MIN_WINDOW_SAMPLES), data.n_samples)
    start = max(0, min(start, stop - MIN_WINDOW_SAMPLES))
    t, y = data.t[start:stop], data.y[start:stop]
    step = step_m if step_m is not None else (data.step_amplitude or release_step(data, release))
    numbers = data.cart_numbers()
    pulled = numbers.index(release.pulled_cart) + 1 if release.pulled_cart in numbers else None
    cut = from_release(t, y, float(max(release.release_time_s, t[0])), step, pulled, data.name)
    note = (f"release {release.number}: {release.release_time_s:.4f} s to {release.end_time_s:.4f} s "
            f"(cart {release.pulled_cart} pulled, {'complete' if release.complete else 'cut by the record'})")
    return replace(cut, notes=(*data.notes, note), columns=data.columns)


def release_step(data: IdData, release: Release) -> float:
    """The pull a release undoes (m): where the pulled cart rests after it, the mean of its
    free response's last period, less where the hand let it go. Positive for a cart let go
    on the negative side of its rest (as the lab's pull-hold-release from -d, step +d),
    negative on the positive side; `DEFAULT_STEP_M` when the cart is not a column of `data`
    or the two coincide."""
    numbers = data.cart_numbers()
    if release.pulled_cart not in numbers:
        return DEFAULT_STEP_M
    y = data.y[:, numbers.index(release.pulled_cart)]
    let_go = float(np.interp(release.release_time_s, data.t, y))
    tail = (data.t > release.end_time_s - release.period_s) & (data.t <= release.end_time_s)
    tail &= data.t > release.release_time_s
    step = float(np.mean(y[tail])) - let_go if np.any(tail) else 0.0
    return step if step != 0.0 else DEFAULT_STEP_M


def releases_of(data: IdData) -> list[Release]:
    """Every release in a loaded record, named by its columns' carts."""
    return find_releases(data.t, data.y, data.cart_numbers())


def select_release(data: IdData, number: int) -> IdData:
    """`ident.fitrun`'s release selector: the record cut to release `number`."""
    return window_of(data, choose(releases_of(data), number))


def moving_columns(data: IdData, release: Release | None) -> list[int]:
    """0-based columns of the carts that move freely: the release's, or without one, the
    columns whose swing is at least `HELD_FRACTION` of the largest (a constant column never)."""
    if release is not None:
        numbers = data.cart_numbers()
        return [numbers.index(c) for c in release.moving_carts if c in numbers]
    swing = np.ptp(data.y, axis=0)
    if float(np.max(swing)) <= 0.0:
        return []
    return [j for j in range(data.n_outputs) if swing[j] >= HELD_FRACTION * float(np.max(swing))]


def select_or_whole(data: IdData, number: int) -> IdData:
    """The record cut to release `number`; for `FIRST_COMPLETE` in a record where no release
    is found but whose release time is known (a daq run's metadata, a `daq export`'s
    comments, `--release-s`), the whole record with the release step there, as loaded."""
    releases = releases_of(data)
    if not releases and (number != FIRST_COMPLETE or data.release_time_s is None):
        check_motion(data.y)   # a record that never moves says so, before "no release"
    if releases or number != FIRST_COMPLETE or data.release_time_s is None:
        return window_of(data, choose(releases, number))
    step = data.step_amplitude or DEFAULT_STEP_M
    whole = from_release(data.t, data.y, data.release_time_s, step, data.pulled_cart, data.name)
    return replace(whole, notes=(*data.notes, *whole.notes, "no release found: the whole record is fitted "
                                 f"from the known release at {data.release_time_s:.4f} s"),
                   columns=data.columns)


def with_found_release(t: ArrayLike, y: ArrayLike, amplitude: float = DEFAULT_STEP_M, pulled_cart: int | None = None,
                       name: str = "") -> IdData:
    """`IdData` of a whole record `y` (N,) or (N, n) m on `t` (N,) s whose release time is not
    known: the release step (`amplitude`, m) at the first complete release `find_releases`
    finds (the first release when the record cuts every one), the pulled cart the finder's
    unless given; the note says so. Raises `IdentValueError` when there is no release."""
    t_arr, _, y_arr = check_arrays(t, None, y)
    releases = find_releases(t_arr, y_arr)
    if not releases:
        check_motion(y_arr)   # a record that never moves says so, before "no release"
    release = choose(releases, FIRST_COMPLETE)
    data = from_release(t_arr, y_arr, release.release_time_s, amplitude,
                        release.pulled_cart if pulled_cart is None else pulled_cart, name)
    note = (f"release time found in the data: {release.release_time_s:.4f} s "
            f"(release {release.number} of {len(releases)}; see `ident releases`)")
    return replace(data, notes=(*data.notes, note))
