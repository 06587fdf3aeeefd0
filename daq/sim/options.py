"""The options of the simulated rig, parsed from a `sim://` URL query.

`sim://[name]?opt=value&opt=value...` — every option has a default; unknown options and
bad values raise `SimOptionError` (a `DaqValueError` and a `serial.SerialException`)
naming the option, what was expected and what was given. `describe_options()` returns
the Markdown table of all options (the README copy is generated from it); the same table
is appended to this docstring at import, so `help(daq.sim.options)` lists every option.

Defaults are a lab-like two-cart rig: cart 1 alone (cart 2 pinned) has
`wn = sqrt((k1 + k2) / m1) = 11.1 rad/s` (1.77 Hz) and `zeta = c1 / (2 sqrt((k1 + k2) m1))
= 0.032`; a 0.15 m pull settles (below 2 mm/s) about 20 s after the release.
"""

from __future__ import annotations

import math
import urllib.parse
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import serial

from daq.errors import DaqValueError

CASES = ("cart1", "cart2", "both", "idle", "handle")
DIALECT_NAMES = ("cartlab", "csv", "ecp")
STUDENT_MODES = ("off", "releases", "handling")


class SimOptionError(DaqValueError, serial.SerialException):
    """A bad `sim://` or `replay://` option: names the option, the expectation and the value."""


@dataclass(frozen=True)
class SimOptions:
    """Parsed options; field docs live in `_TABLE` (one row per option)."""

    # physics
    carts: int = 2
    m1: float = 0.85
    m2: float = 0.75
    k1: float = 60.0
    k2: float = 45.0
    k3: float = 50.0
    c1: float = 0.6
    c2: float = 0.6
    fc1: float = 0.0
    fc2: float = 0.0
    cubic: float = 0.0
    substep_hz: float = 2000.0
    # device
    dialect: str = "cartlab"
    rate_hz: float = 100.0
    counts_per_m: float = 20000.0
    noise_counts: float = 0.1
    clock0_us: int = 0
    seq0: int = 0
    clock_ppm: float = 0.0
    model: str = "cartlab-sim"
    firmware: str = "0.1.0"
    # hand and script
    cases: tuple[str, ...] = ("cart1",)
    repeat: int = 1
    pull_m: float = 0.15
    rest_s: float = 1.0
    pull_s: float = 1.5
    hold_s: float = 2.0
    hold_jitter: float = 0.2
    flick_mps: float = 0.0
    flick_s: float = 0.1
    student: str = "off"
    student_releases: int = 4
    flick_m: float = 0.05
    wander_m: float = 0.003
    follow: float = 0.02
    p_nudge: float = 0.3
    p_touch: float = 0.3
    p_moving: float = 0.25
    tremor_m: float = 5e-5
    settle_mps: float = 0.002
    settle_hold_s: float = 1.0
    ring_max_s: float = 60.0
    idle_s: float = 10.0
    tail_s: float = 2.0
    duration_s: float = 0.0
    # pacing
    realtime: bool = True
    seed: int = 0
    # faults
    garbage: float = 0.0
    corrupt: float = 0.0
    drop: float = 0.0
    disconnect_every_s: float = 0.0
    disconnect_s: float = 1.0
    reopen_failures: int = 2
    reboot_on_reconnect: bool = False
    # output
    capture: str = ""


@dataclass(frozen=True, slots=True)
class Parser:
    """How one option's text becomes a value (`parse` raises ValueError) and what it expects."""

    parse: Callable[[str], Any]
    expected: str


def _float(lo: float, hi: float, lo_open: bool = False) -> Parser:
    def parse(text: str) -> float:
        value = float(text)
        if not math.isfinite(value) or value < lo or value > hi or (lo_open and value == lo):
            raise ValueError
        return value
    return Parser(parse, f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}]")


def _int(lo: int, hi: int) -> Parser:
    def parse(text: str) -> int:
        value = int(text)
        if not lo <= value <= hi:
            raise ValueError
        return value
    return Parser(parse, f"an integer in [{lo}, {hi}]")


def _parse_bool(text: str) -> bool:
    if text.lower() in ("1", "true", "yes", "on"):
        return True
    if text.lower() in ("0", "false", "no", "off"):
        return False
    raise ValueError


def _choice(names: tuple[str, ...]) -> Parser:
    def parse(text: str) -> str:
        if text not in names:
            raise ValueError
        return text
    return Parser(parse, "one of " + ", ".join(names))


def _parse_cases(text: str) -> tuple[str, ...]:
    if text in ("", "none"):
        return ()
    names = tuple(part.strip() for part in text.split(","))
    if not all(name in CASES for name in names):
        raise ValueError
    return names


def _parse_text(text: str) -> str:
    if not text.isprintable() or any(ch in text for ch in ",*$"):
        raise ValueError
    return text


def _parse_path(text: str) -> str:
    if not text:
        raise ValueError
    return text


_bool = Parser(_parse_bool, "0 or 1")
_cases = Parser(_parse_cases, "'none' or a comma list of " + ", ".join(CASES))
_text = Parser(_parse_text, "printable text without , * $")
_path = Parser(_parse_path, "a file path")

_BIG = 1e9
# name -> (parser, unit, description)
_TABLE: dict[str, tuple[Parser, str, str]] = {
    "carts": (_int(1, 2), "", "1: wall-k1-m1-k2-wall, one encoder; 2: wall-k1-m1-k2-m2-k3-wall, two encoders"),
    "m1": (_float(0, 100, True), "kg", "mass of cart 1"),
    "m2": (_float(0, 100, True), "kg", "mass of cart 2"),
    "k1": (_float(0, 1e5), "N/m", "spring wall-cart 1"),
    "k2": (_float(0, 1e5), "N/m", "spring cart 1-cart 2 (wall for carts=1)"),
    "k3": (_float(0, 1e5), "N/m", "spring cart 2-wall"),
    "c1": (_float(0, 1e3), "N s/m", "viscous damper cart 1 to ground"),
    "c2": (_float(0, 1e3), "N s/m", "viscous damper cart 2 to ground"),
    "fc1": (_float(0, 1e3), "N", "Coulomb (dry) friction force on cart 1, static = kinetic"),
    "fc2": (_float(0, 1e3), "N", "Coulomb (dry) friction force on cart 2"),
    "cubic": (_float(-1e4, 1e4), "1/m^2", "hardening of every spring: F = k (e + cubic e^3)"),
    "substep_hz": (_float(100, 1e6), "Hz", "physics step rate (whole steps per sample, at least one); "
                   "every step is ident.physics' simulator, held carts included"),
    "dialect": (_choice(DIALECT_NAMES), "", "what the device prints"),
    "rate_hz": (_float(0.1, 20000), "Hz", "sample rate (cartlab: `$R` changes it)"),
    "counts_per_m": (_float(1, 1e9), "1/m", "encoder resolution"),
    "noise_counts": (_float(0, 1e6), "counts", "Gaussian noise sigma added before quantization"),
    "clock0_us": (_int(0, 2**32 - 1), "us", "device clock at boot (u32; set near 2**32 to provoke a wrap)"),
    "seq0": (_int(0, 2**32 - 1), "", "sequence counter at boot (u32)"),
    "clock_ppm": (_float(-1e5, 1e5), "ppm", "device clock rate error"),
    "model": (_text, "", "model field of `$I`"),
    "firmware": (_text, "", "firmware field of `$I`"),
    "cases": (_cases, "", ("the script: cases run in order (cart1: cart 2 pinned; cart2: cart 1 pinned; "
              "both: cart 1 pulled, cart 2 held at rest, both released; idle: hands off for idle_s; "
              "handle: cart 1 pulled slowly, held, brought back to rest and let go there, no release)")),
    "repeat": (_int(1, 10000), "", "how many times the case list is run"),
    "pull_m": (_float(-1, 1), "m", "the pulled cart is held at -pull_m from its rest"),
    "rest_s": (_float(0, _BIG), "s", "hands off before each case"),
    "pull_s": (_float(0.01, _BIG), "s", "duration of the smooth (minimum-jerk) pull"),
    "hold_s": (_float(0, _BIG), "s", "holding still after the pull (the student zeroes here)"),
    "hold_jitter": (_float(0, 0.9), "", "hold_s is scaled by 1 + U(-j, j), so releases fall between samples"),
    "flick_mps": (_float(-5, 5), "m/s", ("release while moving: the hand accelerates the cart for flick_s "
                  "and lets go at this speed (positive: towards rest; 0: still release)")),
    "flick_s": (_float(0.001, 10), "s", "duration of the flick"),
    "student": (_choice(STUDENT_MODES), "", ("a seeded student instead of `cases` (see `daq/sim/student.py`): "
                "releases: 1 to student_releases flicks from rest or pull-hold-releases of one cart, the other "
                "cart loosely held, nudges, touches, a start in motion; handling: duration_s (default 600 s) of "
                "nudges, touches and slow pulls brought back, no release")),
    "student_releases": (_int(1, 100), "", "the student makes 1 to this many releases in a record"),
    "flick_m": (_float(0.001, 1), "m", "typical extreme of a student's flick (each drawn 0.6-1.6 times this)"),
    "wander_m": (_float(0, 0.1), "m", "wander amplitude of a loosely held cart (each drawn 0.25-1 times this)"),
    "follow": (_float(0, 1), "", ("how much a loosely held cart follows the pulled one through the spring "
               "at rest (each drawn 0.4-1.6 times this; sets the holding hand's stiffness; "
               "0: the cart on the hand's path)")),
    "p_nudge": (_float(0, 1), "", "student: probability of a nudge (out and back by hand) before a release"),
    "p_touch": (_float(0, 1), "", "student: probability that the held cart is moved by hand after a release"),
    "p_moving": (_float(0, 1), "", "student: probability that the record starts in motion"),
    "tremor_m": (_float(0, 0.01), "m", "RMS of the hand tremor (7-11 Hz) while a hand holds a cart"),
    "settle_mps": (_float(0, 10), "m/s", "a ringing case is settled when every free cart moves slower than this"),
    "settle_hold_s": (_float(0, _BIG), "s", "... for this long"),
    "ring_max_s": (_float(0.1, _BIG), "s", "longest ringing before the next case starts anyway"),
    "idle_s": (_float(0, _BIG), "s", "duration of an `idle` case"),
    "tail_s": (_float(0, _BIG), "s", "idle time after the last case before the end of stream"),
    "duration_s": (_float(0, _BIG), "s", ("end of stream at this simulated time (0: script end + tail_s; "
                   "cases=none and 0: never)")),
    "realtime": (_bool, "", "1: paced by the wall clock; 0: as fast as read, deterministic"),
    "seed": (_int(0, 2**63 - 1), "", "seeds noise, tremor, hold jitter and faults (separate streams)"),
    "garbage": (_float(0, 1), "1/line", "probability of a burst of 1-32 random bytes before a line"),
    "corrupt": (_float(0, 1), "1/line", ("probability of corrupting a line: bit flip, truncation, NUL, "
                "non-ASCII byte or 300-byte over-long line")),
    "drop": (_float(0, 1), "1/line", "probability of losing a line (seq still advances)"),
    "disconnect_every_s": (_float(0, _BIG), "s", "unplug the device every this much simulated time (0: never)"),
    "disconnect_s": (_float(0, _BIG), "s", "how long it stays unplugged (lines of that time are lost)"),
    "reopen_failures": (_int(0, 1000), "", "realtime=0 only: failed opens before the device is back"),
    "reboot_on_reconnect": (_bool, "", "the device reboots when plugged back: seq and clock restart, `$I` sent"),
    "capture": (_path, "", "write every byte delivered by read() to this file"),
}

_DEFAULTS = SimOptions()
assert set(_TABLE) == {f.name for f in fields(SimOptions)}


def parse_sim_url(url: str) -> SimOptions:
    """`sim://[name]?opt=value&...` -> SimOptions; raises SimOptionError on any bad option."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "sim":
        raise SimOptionError("url", "a sim://[name]?opt=value&... url", url)
    values: dict[str, Any] = {}
    for name, text in urllib.parse.parse_qsl(parts.query, keep_blank_values=True):
        if name not in _TABLE:
            raise SimOptionError("sim option name", "one of " + ", ".join(_TABLE), name)
        if name in values:
            raise SimOptionError(f"sim option {name!r}", "given once", text)
        parser = _TABLE[name][0]
        try:
            values[name] = parser.parse(text)
        except ValueError:
            raise SimOptionError(f"sim option {name!r}", parser.expected, text) from None
    options = SimOptions(**values)
    _check_consistent(options)
    return options


def _check_consistent(options: SimOptions) -> None:
    if options.carts == 1 and any(case in ("cart2", "both") for case in options.cases):
        raise SimOptionError("sim option 'cases'", "only cart1, idle or handle cases with carts=1",
                             ",".join(options.cases))


def describe_options() -> str:
    """The Markdown table of every `sim://` option: name, default, unit, meaning."""
    rows = ["| option | default | unit | meaning |", "|---|---|---|---|"]
    for name, (_parser, unit, text) in _TABLE.items():
        default = getattr(_DEFAULTS, name)
        if isinstance(default, tuple):
            default = ",".join(default) or "none"
        elif isinstance(default, bool):
            default = int(default)
        rows.append(f"| `{name}` | `{default}` | {unit} | {text} |")
    return "\n".join(rows)


__doc__ = (__doc__ or "") + "\nOptions:\n\n" + describe_options() + "\n"
