"""Issue-10 records from the physics: a student releasing one cart of the two-cart rig 1–4 times.

`make_record(seed)` draws everything from `numpy.random.default_rng([10, seed])`:
- the rig: masses 0.5–3 kg, springs 100–800 N/m, the pulled cart with viscous (ζ 0.005–0.05)
  and dry friction (static 1–1.5 × kinetic; it stops after 4–25 cycles of a 4 cm swing);
- the other cart loosely held: a hand as a soft spring-damper (the held cart follows the
  pulled one by 1.5–6 % through the spring) to a hand position that wanders 100–400 counts
  peak to peak (56,000 counts/m), and is sometimes moved by 3–12 mm 2–5 s after a release;
- releases: flicks from rest (hand path to 3–5 cm in 0.10–0.20 s, let go at 80–100 % of the
  path, while it still moves) or pull-hold-releases (3–12 cm, held 0.5–2 s, tremor); the
  first after 0.2–2 s of quiet, a later one after the cart stopped, or back to back (grabbed
  1.5–3.5 s after the last release, while it may still ring); nudges (out 3–10 mm and back,
  let go where taken) before a release; a record that starts in the tail of a release made
  before it; the record ends 1–6 s after the last release (often cutting it);
- handling-only records (`make_record(seed, handling=True)`): nudges, moves of the held cart
  and slow pulls brought back and let go where taken, no release.
Rates: 50, 100, 200 or 1000 Hz, or the ECP Teensy's irregular 1 ms / 2 ms clock.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from physics import Cart, Chain, Path, Simulator, quintic, wander

COUNTS_PER_M = 56000.0
RATES = ("50", "100", "200", "1000", "ecp")


@dataclass
class Record:
    seed: int
    t: np.ndarray  # (N,) s, the device clock (integer ms)
    counts: np.ndarray  # (N, 2) encoder counts
    releases: list[dict[str, Any]] = field(default_factory=list)  # truth per release
    info: dict[str, Any] = field(default_factory=dict)


class HeldHand:
    """The other cart's hand position: wander plus smooth moves (touches) added as planned."""

    def __init__(self, base: Path) -> None:
        self.base = base
        self.moves: list[Path] = []

    def __call__(self, t: float) -> tuple[float, float]:
        x, v = self.base(t)
        for mv in self.moves:
            dx, dv = mv(t)
            x, v = x + dx, v + dv
        return x, v


def _time_base(rng: np.random.Generator, rate: str, t0: float, t1: float) -> np.ndarray:
    if rate == "ecp":
        steps = np.where(rng.random(int((t1 - t0) * 1000) + 10) < 0.87, 1, 2)
        ms = np.round(t0 * 1000) + np.cumsum(steps)
        return ms[ms <= t1 * 1000] / 1000.0
    r = int(rate)
    n0 = int(np.ceil(t0 * r))
    return np.arange(n0, int(t1 * r) + 1) * (1000 // r) / 1000.0


class Student:
    """Drives the simulator segment by segment: hand paths on the pulled cart, free spells."""

    def __init__(self, rng: np.random.Generator, chain: Chain, pulled: int, hand: HeldHand, t0: float) -> None:
        self.rng, self.chain, self.pulled, self.hand = rng, chain, pulled, hand
        self.sim = Simulator(chain, np.zeros(2), np.zeros(2), t0)
        self.pieces: list[tuple[float, float]] = []  # (t0, t1) spans simulated
        self.grid: np.ndarray = np.zeros(0)
        self.out: np.ndarray = np.zeros((0, 2))

    def advance(self, t1: float) -> None:
        res = self.sim.run(t1, self.grid)
        self.out = np.where(np.isnan(self.out), res, self.out)

    def state(self) -> tuple[float, float, float]:
        i = self.pulled
        f = self.chain.forces(self.sim.t, self.sim.x, self.sim.v)[i]
        c = self.chain.carts[i]
        if c.fk > 0 and abs(self.sim.v[i]) > 1e-12:
            f -= c.fk * np.sign(self.sim.v[i])
        elif abs(f) <= c.fs:
            f = 0.0
        else:
            f -= c.fk * np.sign(f)
        return float(self.sim.x[i]), float(self.sim.v[i]), float(f / c.m)

    def hand_path(self, path: Path, t_end: float) -> None:
        """The hand holds the pulled cart on `path` until t_end, then lets go."""
        self.chain.held = {self.pulled: path}
        self.advance(t_end)
        x, v = path(t_end)
        self.sim.x[self.pulled], self.sim.v[self.pulled] = x, v
        self.chain.held = {}

    def stopped(self) -> bool:
        return abs(self.sim.v[self.pulled]) < 1e-9 and self.sim.mode[self.pulled] == "stick"

    def wait_stop(self, limit: float) -> None:
        t_lim = self.sim.t + limit
        while not self.stopped() and self.sim.t < t_lim:
            self.advance(self.sim.t + 0.1)


def make_record(seed: int, handling: bool = False, rate: str | None = None) -> Record:
    """Draw one record; `rate` (one of RATES) overrides the drawn rate, every other draw unchanged."""
    rng = np.random.default_rng([10, seed, int(handling)])
    drawn = str(rng.choice(RATES))
    rate = rate or drawn
    m1, m2 = rng.uniform(0.5, 3.0, 2)
    k1, k2, k3 = rng.uniform(100.0, 800.0, 3)
    pulled = int(rng.integers(0, 2))
    other = 1 - pulled
    k_tot = (k1 + k2) if pulled == 0 else (k2 + k3)
    k_oth = (k1 + k2) if other == 0 else (k2 + k3)
    m_p, m_o = (m1, m2) if pulled == 0 else (m2, m1)
    n_cycles = rng.uniform(4.0, 25.0)
    fk = k_tot * 0.04 / (4 * n_cycles)
    zeta = rng.uniform(0.005, 0.05)
    follow = rng.uniform(0.015, 0.06)
    kh = k2 / follow - k_oth
    ptp = rng.uniform(100, 400) / COUNTS_PER_M
    hand = HeldHand(wander(rng, ptp))
    pc = Cart(m=m_p, c=2 * zeta * np.sqrt(k_tot * m_p), fk=fk, fs=fk * rng.uniform(1.0, 1.5))
    oc = Cart(m=m_o, c=0.3, kh=kh, ch=2 * 0.5 * np.sqrt(kh * m_o), h=hand)
    carts = [pc, oc] if pulled == 0 else [oc, pc]
    chain = Chain(carts, k1=k1, k2=k2, k3=k3)
    info: dict[str, Any] = dict(rate=rate, pulled_cart=pulled + 1, m1=m1, m2=m2, k1=k1, k2=k2, k3=k3,
                                fk_accel=fk / m_p, zeta=zeta, follow=follow, wander_counts=ptp * COUNTS_PER_M,
                                handling=handling, coulomb_cycles=n_cycles)
    moving = (not handling) and rng.random() < 0.25
    t_start = -rng.uniform(0.2, 1.0) if moving else 0.0
    st = Student(rng, chain, pulled, hand, t_start)
    # plan in a generous grid; trimmed to the record at the end
    st.grid = _time_base(rng, drawn, t_start, 120.0)  # drawn first: the later draws do not depend on `rate`
    if rate != drawn:
        st.grid = _time_base(np.random.default_rng([10, seed, 99]), rate, t_start, 120.0)
    st.out = np.full((len(st.grid), 2), np.nan)
    events: list[str] = []
    if moving:  # the tail of a release made before the record began
        x0 = float(rng.choice([-1, 1]) * rng.uniform(0.02, 0.05))
        st.sim.x[pulled] = x0
        st.sim.mode[pulled] = "slide"
        st.advance(0.0)
        events.append("starts in motion")
    releases: list[dict[str, Any]] = []
    if handling:
        _handling(st, rng, events, duration=60.0)
        t_end = 60.0
    else:
        n_rel = int(rng.integers(1, 5))
        for i in range(n_rel):
            _one_release(st, rng, i, releases, events)
        t_end = releases[-1]["t_r"] + rng.uniform(1.0, 6.0)
    st.advance(t_end)
    keep = (st.grid >= 0.0) & (st.grid <= t_end)
    t = st.grid[keep]
    x = st.out[keep]
    # the encoder was zeroed wherever the carts were at power-on; 0.1-count noise before the counts
    offs = rng.uniform(-0.01, 0.01, 2)
    counts = np.round((x + offs) * COUNTS_PER_M + rng.normal(0, 0.1, x.shape)).astype(np.int64)
    for r in releases:
        r["cut"] = bool(r["ring_until"] > t_end) if "ring_until" in r else None
    if releases:
        releases[0]["after_motion_start"] = moving
        releases[-1]["cut_truth"] = _cut_truth(t, x[:, pulled], releases[-1]["wn"])
    info["events"] = events
    return Record(seed, t, counts, releases, info)


def _quiet(st: Student, rng: np.random.Generator, lo: float, hi: float) -> None:
    st.wait_stop(15.0)
    st.advance(st.sim.t + rng.uniform(lo, hi))


def _nudge(st: Student, rng: np.random.Generator) -> None:
    x, _, _ = st.state()
    t0 = st.sim.t
    d = float(rng.choice([-1, 1]) * rng.uniform(0.003, 0.010))
    dur = rng.uniform(0.15, 0.3)
    out = quintic(t0, t0 + dur, (x, 0, 0), (x + d, 0, 0))
    back = quintic(t0 + dur, t0 + 2 * dur, (x + d, 0, 0), (x, 0, 0))
    st.hand_path(lambda t: out(t) if t < t0 + dur else back(t), t0 + 2 * dur)
    st.sim.v[st.pulled] = 0.0


def _touch(st: Student, rng: np.random.Generator, when: float) -> None:
    d = float(rng.choice([-1, 1]) * rng.uniform(0.003, 0.012))
    dur = rng.uniform(0.2, 0.6)
    st.hand.moves.append(quintic(when, when + dur, (0, 0, 0), (d, 0, 0)))


def _one_release(st: Student, rng: np.random.Generator, i: int, releases: list[dict[str, Any]],
                 events: list[str]) -> None:
    back_to_back = i > 0 and rng.random() < 0.4
    nudged = False
    if back_to_back:
        st.advance(releases[-1]["t_r"] + rng.uniform(1.5, 3.5))
        events.append(f"release {i + 1}: grabbed while ringing")
    else:
        _quiet(st, rng, 0.2, 2.0)
        if rng.random() < 0.3:
            _nudge(st, rng)
            nudged = True
            events.append(f"release {i + 1}: nudge before")
            _quiet(st, rng, 0.4, 1.5)
    x, v, a = st.state()
    t0 = st.sim.t
    sgn = float(rng.choice([-1, 1]))
    if rng.random() < 0.6:
        kind = "flick"
        amp, dur, frac = rng.uniform(0.03, 0.05), rng.uniform(0.10, 0.20), rng.uniform(0.8, 1.0)
        path = quintic(t0, t0 + dur, (x, v, a), (sgn * amp, 0, 0))
        t_r = t0 + frac * dur
    else:
        kind = "pull-hold"
        amp, dur, hold = rng.uniform(0.03, 0.12), rng.uniform(0.4, 1.0), rng.uniform(0.5, 2.0)
        pull = quintic(t0, t0 + dur, (x, v, a), (sgn * amp, 0, 0))
        tr_a, tr_f = rng.uniform(0, 5e-5), rng.uniform(7, 11)

        def path(t: float, pull: Path = pull, t1: float = t0 + dur) -> tuple[float, float]:
            p, pv = pull(t)
            if t <= t1:
                return p, pv
            w = 2 * np.pi * tr_f
            ramp = min((t - t1) / 0.2, 1.0)
            return p + ramp * tr_a * np.sin(w * (t - t1)), pv + ramp * tr_a * w * np.cos(w * (t - t1))

        t_r = t0 + dur + hold
    xr, vr = path(t_r)
    a_hand = (path(t_r - 1e-6)[1] - path(t_r - 3e-6)[1]) / 2e-6
    st.hand_path(path, t_r)
    _, _, a_free = st.state()
    wn = float(np.sqrt(((st.chain.k1 + st.chain.k2) if st.pulled == 0 else (st.chain.k2 + st.chain.k3))
                       / st.chain.carts[st.pulled].m))
    rel = {"t_r": float(t_r), "kind": kind, "x_r": float(xr), "v_r": float(vr),
           "accel_jump_m_s2": float(abs(a_hand - a_free)), "back_to_back": back_to_back, "wn": wn,
           "nudge_before": nudged, "touch_after": False, "after_motion_start": False}
    releases.append(rel)
    if rng.random() < 0.3:
        when = t_r + rng.uniform(2.0, 5.0)
        _touch(st, rng, when)
        rel["touch_after"] = True
        events.append(f"release {i + 1}: other cart moved at {when:.2f} s")
    # how long it rings (for 'cut'): simulate ahead on a copy is costly; the next step knows
    st.advance(t_r + 1e-6)
    rel["ring_until"] = _ring_end(st)


def _cut_truth(t: np.ndarray, x: np.ndarray, wn: float) -> bool | None:
    """Is the last release cut by the record's end? True when the pulled cart still swings by more
    than 5 mm over the last period, False when it has rested (within 0.3 mm) for the last second,
    None in between (not judged)."""
    last = x[t >= t[-1] - 2 * np.pi / wn]
    still = x[t >= t[-1] - 1.0]
    if np.ptp(last) > 0.005:
        return True
    if np.ptp(still) < 0.0003:
        return False
    return None


def _ring_end(st: Student) -> float:
    """Time the pulled cart stops (its amplitude decays by friction), estimated from the state."""
    c = st.chain.carts[st.pulled]
    k = (st.chain.k1 + st.chain.k2) if st.pulled == 0 else (st.chain.k2 + st.chain.k3)
    wn = np.sqrt(k / c.m)
    x, v, _ = st.state()
    amp = np.hypot(x, v / wn)
    cycles = amp * k / (4 * c.fk)
    return st.sim.t + cycles * 2 * np.pi / wn


def _handling(st: Student, rng: np.random.Generator, events: list[str], duration: float) -> None:
    while st.sim.t < duration - 5.0:
        _quiet(st, rng, 1.0, 4.0)
        what = rng.choice(["nudge", "touch", "slow pull"])
        if what == "nudge":
            _nudge(st, rng)
        elif what == "touch":
            _touch(st, rng, st.sim.t + 0.1)
            st.advance(st.sim.t + 1.0)
        else:
            x, _, _ = st.state()
            t0 = st.sim.t
            d = float(rng.choice([-1, 1]) * rng.uniform(0.02, 0.06))
            d1, hold = rng.uniform(1.0, 2.0), rng.uniform(0.3, 1.5)
            out = quintic(t0, t0 + d1, (x, 0, 0), (x + d, 0, 0))
            back = quintic(t0 + d1 + hold, t0 + 2 * d1 + hold, (x + d, 0, 0), (x, 0, 0))
            tb = t0 + d1 + hold

            def pull(t: float, o: Path = out, b: Path = back, tb: float = tb) -> tuple[float, float]:
                return o(t) if t < tb else b(t)

            st.hand_path(pull, t0 + 2 * d1 + hold)
            st.sim.v[st.pulled] = 0.0
        events.append(f"{what} at {st.sim.t:.2f} s")


def ecp_lines(rec: Record) -> str:
    """The Teensy's stream: `cart1pos:cart2pos:target:duty:time_ms`."""
    ms = np.round(rec.t * 1000).astype(np.int64)
    return "".join(f"{c1}:{c2}:0:0:{m}\n" for (c1, c2), m in zip(rec.counts.tolist(), ms.tolist()))


def csv_text(rec: Record) -> str:
    rows = "".join(f"{t:.3f},{c1 / COUNTS_PER_M:.9g},{c2 / COUNTS_PER_M:.9g}\n"
                   for t, (c1, c2) in zip(rec.t.tolist(), rec.counts.tolist()))
    return "time_s,pos1_m,pos2_m\n" + rows


def tsv_text(rec: Record) -> str:
    """The ECP lab app's export: tab-separated, a header, counts, time in s with 3 decimals."""
    rows = "".join(f"{k + 1}\t{t:.3f}\t{c1}\t{c2}\t0\n" for k, (t, (c1, c2)) in
                   enumerate(zip(rec.t.tolist(), rec.counts.tolist())))
    return "Sample\tTime\tEncoder 1 Pos\tEncoder 2 Pos\tControl Effort\n" + rows
