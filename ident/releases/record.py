"""The record of one release found in a raw record (see `ident.releases.finder`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal

#: What ended a free response: the cart's next release, a hand touching a cart (handling,
#: the other cart moved), or the end of the record.
EndedBy = Literal["release", "touch", "record_end"]

#: A cart whose swing is below this fraction of the pulled (largest-swinging) cart's is held:
#: it may wander by hand or follow weakly through the spring, and enters a fit as measured
#: input, never as a free cart (`ident releases`' moving carts, `ident diagnose`'s carts).
HELD_FRACTION = 0.25


@dataclass(frozen=True)
class Release:
    """One release: the hand lets go at `release_time_s` and the free response lasts until
    `end_time_s` (both s, on the record's own time base).

    - `number`: 1-based position in the record (`--release K`);
    - `pulled_cart`: the cart the hand let go (a cart number, see `find_releases(carts=...)`);
    - `moving_carts`: the carts that move freely after the release, the pulled one included;
      a cart whose swing is small beside the pulled cart's is held (it may wander or follow
      weakly through the spring) and is not among them;
    - `amplitudes_m`: per cart (in `carts` order), the largest deviation from the rest level
      during the first period of the free response (m);
    - `complete`: False when the record ends while the pulled cart still rings (cut);
    - `ended_by`: what ended the free response (`EndedBy`);
    - `period_s`: the oscillation period seen in the free response.
    """

    number: int
    release_time_s: float
    end_time_s: float
    pulled_cart: int
    moving_carts: tuple[int, ...]
    amplitudes_m: tuple[float, ...]
    complete: bool
    ended_by: EndedBy
    period_s: float

    @property
    def duration_s(self) -> float:
        """Length of the free response (s)."""
        return self.end_time_s - self.release_time_s

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (lists for tuples)."""
        out = asdict(self)
        out["moving_carts"] = list(self.moving_carts)
        out["amplitudes_m"] = list(self.amplitudes_m)
        out["duration_s"] = self.duration_s
        return out
