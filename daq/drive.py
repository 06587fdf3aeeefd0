"""The rig's drive in the stream (`DataFrame.drive`: the `ecp` line's target and duty): where it
switched, so a run it began is told from a hand's release. Pure: device nanoseconds in.

A motor pulse moves a cart to a new rest and back; in the positions alone each edge is a
release from a still hold. A release dated within `LEAD_NS` after or `LAG_NS` before a switch is
the drive's step (the 2025 ECP-210 motor pulses' edges were dated 8 ms after and 1 ms before
the switch); it is re-dated to the switch when the drive had been steady for `LEAD_NS` before
it (a closed loop's drive changes at every sample). A candidate the hand's rules turn down
within `RECENT_NS` after such a switch is the drive's step all the same (the 2023 open-loop
3 mm steps swing back toward their hold: "came back").
"""

from __future__ import annotations

from collections import deque

LEAD_NS = 200_000_000
LAG_NS = 50_000_000
RECENT_NS = 1_000_000_000
# switches are kept this long (device ns): a release is confirmed up to a few seconds after it
KEEP_NS = 5_000_000_000


class DriveSwitches:
    """Feed every sample's drive with `push`; ask `at_release` and `recent` about its switches."""

    def __init__(self) -> None:
        self._drive: tuple[float, float] | None = None
        self._since_ns = 0
        # (device ns of the first sample of a new drive, ns the drive had been steady before it)
        self._switches: deque[tuple[int, int]] = deque()
        self._last_release_ns = -(2**62)   # the last run's release (`at_release`)

    def push(self, t_ns: int, drive: tuple[float, float] | None) -> None:
        """One sample's drive (None: the stream has none)."""
        if drive != self._drive and drive is not None:
            switches = self._switches
            if self._drive is not None:
                switches.append((t_ns, t_ns - self._since_ns))
                while switches[0][0] < t_ns - KEEP_NS:   # a closed loop's drive switches every sample
                    switches.popleft()
            self._drive, self._since_ns = drive, t_ns

    def at_release(self, release_ns: int) -> tuple[bool, int]:
        """Whether the drive switched about a release dated `release_ns` (so the run is the
        drive's), and the release instant: the first such switch's when the drive had been
        steady before it, else `release_ns`. The run is taken to start there."""
        near = [(t, steady) for t, steady in self._switches if release_ns - LEAD_NS <= t <= release_ns + LAG_NS]
        if near and near[0][1] >= LEAD_NS:
            release_ns = near[0][0]
        self._last_release_ns = release_ns
        return bool(near), release_ns

    def recent(self, t_ns: int) -> int | None:
        """The last switch of a drive steady for `LEAD_NS` before it, within `RECENT_NS` before
        `t_ns` and later than the last run's release (device ns), or None."""
        for switch, steady in reversed(self._switches):
            if switch < t_ns - RECENT_NS or switch <= self._last_release_ns:
                return None
            if steady >= LEAD_NS and switch <= t_ns:
                return switch
        return None


__all__ = ["KEEP_NS", "LAG_NS", "LEAD_NS", "RECENT_NS", "DriveSwitches"]
