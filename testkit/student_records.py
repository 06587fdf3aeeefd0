"""Seeded raw records of students' hand releases, generated from the physics (issue 10).

Written from the physical description and the issue's ranges, independently of
`ident.releases` (the code under test): the carts are simulated by `testkit.effects`' own
event-driven stick/slip integrator; only the sampled positions are handed to the finder,
the truth (release instants, pulled cart, cut or complete) is kept apart.

A record (two carts, wall –k1– cart 1 –k2– cart 2 –k3– wall, k_i ∈ [20, 120] N/m, m_i ∈
[0.5, 1.5] kg, ζ_i ∈ [0.005, 0.04], kinetic dry friction on the pulled cart so that a cycle
loses 2–15 % of a 4 cm swing, static 1–1.3× kinetic):
- the pulled cart (1 or 2); the other held by a loose hand (a hand spring that lets it follow
  at 2–5 %) wandering by 2–7 mm (100–400 counts at 56,000 counts/m), or (`both_free`) free;
- 1–4 releases, each a *flick* (from where the hand grabs the cart to ±3–5 cm from rest in
  0.1–0.2 s, let go while moving at up to ±0.3 wn·|x1|: near the first extreme) or a
  *pull-hold-release* (pulled to ±3–10 cm in 0.4–0.8 s, held still 0.3–1 s, let go);
  a release may come while the previous one still rings (back-to-back);
- before a release, sometimes a *nudge*: the hand moves the cart 2–8 mm and back in
  0.2–0.5 s and lets go where it took it (no ringing from rest; a cart taken while it rang is
  let go away from its rest and rings: `StudentRecord.catches_s`);
- after a release, sometimes a *touch*: 1.5–3 s later the hand moves the held cart 3–8 mm
  in 0.3–0.6 s (there and back or to a new place), which moves the pulled cart through the
  spring;
- sometimes the record starts in motion (the tail of an earlier release, 1–4 cm);
- the last release is cut by the end of the record (0.8–1.5 s after it) or rings out;
- sampled at the given rate, read by an encoder of 1/56,000 m (counts) or 10 µm with white
  noise of 0–10 µm.
`handling_record` draws records with nudges and touches only (no release).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from testkit.effects import hand as hands
from testkit.effects.integrate import Phase, simulate
from testkit.effects.rig import FloatArray, HandSpring, Rig, Trajectory, make_rig

RATES_HZ = (50.0, 100.0, 200.0, 1000.0)
# a nudge whose cart swings by this much or more on its own within `CATCH_WINDOW_S` after the
# hand let go (before anything else the plan does) was a catch of a ringing cart
CATCH_SWING_M = 0.005
CATCH_WINDOW_S = 1.0


@dataclass(frozen=True)
class TrueRelease:
    """Where the hand let go (s), the pulled cart (1, 2), how, and whether the record cut it."""

    time_s: float
    pulled_cart: int
    kind: str
    cut: bool = False
    #: the jump in the pulled cart's acceleration as the hand lets go (m/s²): the hand's
    #: force per unit mass there (`_let_go_jump`)
    jump_m_s2: float = float("nan")


@dataclass(frozen=True)
class StudentRecord:
    """`t` (N,) s and `y` (N, 2) m: what the finder sees. The rest is the truth."""

    t: FloatArray
    y: FloatArray
    releases: tuple[TrueRelease, ...]
    both_free: bool
    rate_hz: float
    events: tuple[str, ...] = field(default=())
    touches_s: tuple[float, ...] = field(default=())
    #: the readings' noise RMS (m): the Gaussian noise and the encoder's count, q²/12
    noise_m: float = float("nan")
    #: where a nudge let go of a cart that then swung by `CATCH_SWING_M` or more on its own (the
    #: hand took it while it rang and let it go away from its rest: a release the plan did not
    #: make, physically one all the same): a run there is neither required nor false
    catches_s: tuple[float, ...] = field(default=())

    def in_data(self, snr: float = 10.0) -> list[bool]:
        """Per release: whether its instant is in the data (`instants_in_data`)."""
        return instants_in_data([r.jump_m_s2 for r in self.releases], self.rate_hz, self.noise_m, snr)


def instants_in_data(jumps_m_s2: list[float], rate_hz: float, noise_m: float, snr: float = 10.0) -> list[bool]:
    """Per release: whether its instant is in the data, the acceleration jump as the hand lets go
    moving the cart by at least `snr` noise RMS within one sample period (½ |Δa| T²); a softer
    let-go leaves the free response indistinguishable from the hand's motion for more than a
    sample."""
    step = 1.0 / rate_hz
    return [0.5 * abs(a) * step * step >= snr * noise_m for a in jumps_m_s2]


def _bump(t0: float, duration: float, height: float, back: bool) -> Trajectory:
    """Displacement of a hand moving by `height` over `duration` (min-jerk), and back if `back`."""
    def trajectory(t: float) -> tuple[float, float]:
        s = min(max((t - t0) / duration, 0.0), 1.0)
        if back:   # sin² there and back: height at the middle
            return (height * np.sin(np.pi * s) ** 2, height * np.pi * np.sin(2 * np.pi * s) / duration)
        return (height * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5),
                height * (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / duration)
    return trajectory


def _from(x0: float, trajectory: Trajectory) -> Trajectory:
    return lambda t: (x0 + trajectory(t)[0], trajectory(t)[1])


def _hermite(t0: float, t1: float, x0: float, x1: float, v1: float) -> Trajectory:
    """From (x0, 0) at t0 to (x1, v1) at t1, C¹ cubic: the flick."""
    shape = hands.flick(t0, t1, x1 - x0, v1)
    return _from(x0, shape)


def _pull_hold(t0: float, pull: float, hold_s: float, x0: float, x1: float) -> Trajectory:
    move = _bump(t0, pull, x1 - x0, back=False)
    return lambda t: (x0 + move(t)[0], move(t)[1]) if t < t0 + pull else (x1, 0.0)


@dataclass
class _Plan:
    rig: Rig
    pulled: int
    wn: float
    steps: list[tuple[str, float, float, dict[str, float]]] = field(default_factory=list)


def _rig(rng: np.random.Generator, pulled: int, both_free: bool,
         touches: list[tuple[float, float, float, bool]]) -> tuple[Rig, float]:
    m = rng.uniform(0.5, 1.5, 2)
    k = rng.uniform(20.0, 120.0, 3)
    zeta = rng.uniform(0.005, 0.04, 2)
    c = 2 * zeta * np.sqrt(np.array([k[0] + k[1], k[1] + k[2]]) * m)
    springs = ((0, None, float(k[0])), (0, 1, float(k[1])), (1, None, float(k[2])))
    other = 1 - pulled
    hand_list: tuple[HandSpring, ...] = ()
    if not both_free:
        wander = hands.wander(rng, rng.uniform(2e-3, 7e-3))
        bumps = [_bump(t0, d, h, back) for t0, d, h, back in touches]

        def target(t: float) -> tuple[float, float]:
            x, v = wander(t)
            for b in bumps:
                bx, bv = b(t)
                x, v = x + bx, v + bv
            return x, v

        k_h = float(k[1] / rng.uniform(0.02, 0.05))
        hand_list = (HandSpring(other, k_h, k_h * rng.uniform(0.02, 0.03), target),)
    kk = np.array([k[0] + k[1], k[1] + k[2]])
    wn = float(np.sqrt(kk[pulled] / m[pulled]))
    lose = rng.uniform(0.02, 0.15)
    kinetic = np.zeros(2)
    kinetic[pulled] = lose * wn ** 2 * 0.04 / 4
    rig = make_rig(tuple(m), springs, tuple(c), kinetic=tuple(kinetic),
                   static=tuple(kinetic * rng.uniform(1.0, 1.3)), hands=hand_list)
    return rig, wn


def student_record(seed: int, rate_hz: float, releases: int | None = None, *,
                   both_free: bool | None = None, start_in_motion: bool | None = None) -> StudentRecord:
    """One seeded record (see the module docstring); counts drawn unless given."""
    return student_records(seed, (rate_hz,), releases, both_free=both_free,
                           start_in_motion=start_in_motion)[rate_hz]


def student_records(seed: int, rates_hz: tuple[float, ...], releases: int | None = None, *,
                    both_free: bool | None = None, start_in_motion: bool | None = None
                    ) -> dict[float, StudentRecord]:
    """The record of `seed` sampled at each rate: `student_records(s, rates)[r]` equals
    `student_record(s, r)` sample for sample, at the cost of one simulation (the carts'
    motion does not depend on the rate: it is integrated once and read on every grid)."""
    rng = np.random.default_rng(seed)
    n_rel = int(releases if releases is not None else rng.integers(1, 5))
    both = bool(rng.random() < 0.2) if both_free is None else both_free
    pulled = 0 if both else int(rng.integers(0, 2))
    moving = bool(rng.random() < 0.25) if start_in_motion is None else start_in_motion
    # the timeline first (the hand's touches are part of the held cart's hand target)
    cursor = float(rng.uniform(1.0, 3.0)) if moving else float(rng.uniform(0.3, 1.0))
    plan: list[tuple[str, float, dict[str, float]]] = []
    touches: list[tuple[float, float, float, bool]] = []
    events: list[str] = ["start_in_motion"] if moving else []
    for i in range(n_rel):
        if rng.random() < 0.3:
            d = float(rng.uniform(0.2, 0.5))
            height = float(rng.choice([-1, 1]) * rng.uniform(2e-3, 8e-3))
            plan.append(("nudge", cursor, {"duration": d, "height": height}))
            cursor += d + float(rng.uniform(0.3, 0.8))
            events.append("nudge")
        flick = rng.random() < 0.7
        sign = float(rng.choice([-1.0, 1.0]))
        if flick:
            d = float(rng.uniform(0.1, 0.2))
            spec = {"duration": d, "x1": sign * float(rng.uniform(0.03, 0.05)), "v1": float(rng.uniform(-0.3, 0.3))}
            plan.append(("flick", cursor, spec))
        else:
            pull, hold_s = float(rng.uniform(0.4, 0.8)), float(rng.uniform(0.3, 1.0))
            d = pull + hold_s
            plan.append(("hold", cursor, {"duration": d, "pull": pull, "x1": sign * float(rng.uniform(0.03, 0.1))}))
        release_at = cursor + d
        last = i == n_rel - 1
        ring = float(rng.uniform(0.8, 1.5)) if last and rng.random() < 0.5 else float(rng.uniform(2.0, 4.5))
        if last:
            plan.append(("end", release_at + ring, {}))
        if not both and rng.random() < 0.3 and ring > 2.5:
            t_touch = release_at + float(rng.uniform(1.5, min(3.0, ring - 0.8)))
            dur = float(rng.uniform(0.3, 0.6))
            height = float(rng.choice([-1, 1]) * rng.uniform(3e-3, 8e-3))
            touches.append((t_touch, dur, height, bool(rng.random() < 0.5)))
            events.append("touch")
        cursor = release_at + ring
        if not last and rng.random() < 0.2:
            cursor -= ring * float(rng.uniform(0.4, 0.6))   # back-to-back: grabbed while ringing
            events.append("back_to_back")
            touches[:] = [tt for tt in touches if tt[0] + tt[1] < cursor - 0.3]
    rig, wn = _rig(rng, pulled, both, touches)
    return _simulate(rng, rig, wn, pulled, plan, rates_hz, moving, both, tuple(events),
                     tuple(tt[0] for tt in touches))


def _let_go_jump(rig: Rig, path: Trajectory, t: float, z: FloatArray, cart: int) -> float:
    """The pulled cart's acceleration on its hand's path just before `t` less the free one
    just after (the state `z` = (x, v) there; dry friction against the motion, or against the
    net force when the cart is still)."""
    step = 1e-6
    held = (path(t)[1] - path(t - step)[1]) / step
    n = rig.n
    free = float(rig.accel(t, z[:n], z[n:])[cart])
    v = float(z[n + cart])
    free -= float(rig.kinetic[cart]) * float(np.sign(v if abs(v) > 1e-9 else free))
    return held - free


def _grids(end: float, rates_hz: tuple[float, ...]) -> tuple[FloatArray, dict[float, FloatArray]]:
    """Each rate's sample times `k / rate` on [0, end] and their union (sorted, exact floats)."""
    grids = {r: np.arange(int(np.floor(end * r)) + 1) / r for r in rates_hz}
    return np.unique(np.concatenate(list(grids.values()))), grids


def _on_grid(t_all: FloatArray, x_all: FloatArray, t: FloatArray) -> FloatArray:
    """The rows of `x_all` (sampled at `t_all`) at the times `t` (a subset of `t_all`)."""
    return x_all[np.searchsorted(t_all, t)]


def _simulate(rng: np.random.Generator, rig: Rig, wn: float, pulled: int,
              plan: list[tuple[str, float, dict[str, float]]], rates_hz: tuple[float, ...], moving: bool,
              both: bool, events: tuple[str, ...], touches: tuple[float, ...]) -> dict[float, StudentRecord]:
    end = plan[-1][1]
    t, grids = _grids(end, rates_hz)
    x = np.full((t.size, 2), np.nan)
    z = np.zeros(4)
    if moving:
        z[pulled] = float(rng.choice([-1, 1]) * rng.uniform(0.01, 0.04))
    clock = 0.0
    truth: list[TrueRelease] = []
    catches: list[float] = []

    def advance(phase: Phase) -> None:
        nonlocal z, clock
        inside = (t >= phase.start) & (t < phase.end) if phase.end < end else (t >= phase.start)
        seg, ends = simulate(rig, [phase], t[inside], z)
        x[inside] = seg
        z, clock = ends[-1], phase.end

    for kind, start, spec in plan:
        advance(Phase(clock, start))
        if kind == "end":
            break
        x0 = float(z[pulled])
        if kind == "nudge":
            traj = _from(x0, _bump(start, spec["duration"], spec["height"], back=True))
        elif kind == "flick":
            traj = _hermite(start, start + spec["duration"], x0, spec["x1"], spec["v1"] * wn * abs(spec["x1"]))
        else:
            traj = _pull_hold(start, spec["pull"], spec["duration"] - spec["pull"], x0, spec["x1"])
        advance(Phase(start, start + spec["duration"], {pulled: traj}))
        if kind == "nudge":
            if _rings_after(rig, z, pulled, start + spec["duration"], next(s for _, s, _ in plan if s > start)):
                catches.append(start + spec["duration"])
        else:
            let_go = start + spec["duration"]
            truth.append(TrueRelease(let_go, pulled + 1, kind, jump_m_s2=_let_go_jump(rig, traj, let_go, z, pulled)))
    # the encoder's draws start from the same generator state for every rate (as in a record
    # generated at that rate alone)
    state = rng.bit_generator.state
    records = {}
    for rate_hz, t_r in grids.items():
        rng.bit_generator.state = state
        records[rate_hz] = dataclasses.replace(
            _sampled(rng, t_r, _on_grid(t, x, t_r), truth, end, pulled, touches, both, rate_hz, events),
            catches_s=tuple(catches))
    return records


def _rings_after(rig: Rig, z: FloatArray, cart: int, let_go: float, until: float) -> bool:
    """Whether `cart`, let go at `let_go` in state `z`, swings by `CATCH_SWING_M` or more on its
    own within `CATCH_WINDOW_S` (and before `until`, the plan's next step), on a 1 ms grid of its
    own (the record's grid is the rates asked for: a swing near the bar would depend on them)."""
    end = min(let_go + CATCH_WINDOW_S, until)
    grid = let_go + np.arange(int((end - let_go) * 1000.0) + 1) / 1000.0
    seg, _ = simulate(rig, [Phase(let_go, end)], grid, z)
    return bool(np.ptp(seg[:, cart]) >= CATCH_SWING_M)


def _sampled(rng: np.random.Generator, t: FloatArray, x: FloatArray, truth: list[TrueRelease],
             end: float, pulled: int, touches: tuple[float, ...], both: bool, rate_hz: float,
             events: tuple[str, ...]) -> StudentRecord:
    """The record at one rate: the truth's last release marked cut or not, encoder counts."""
    # cut: the pulled cart still swings by more than 1 mm in the record's last second, and
    # no touch ended its free response before
    cut = bool(np.ptp(x[t >= end - 1.0, pulled]) > 1e-3) and not any(s > truth[-1].time_s for s in touches)
    last = dataclasses.replace(truth[-1], cut=cut)
    quantum = 1.0 / 56000.0 if rng.random() < 0.5 else 1e-5
    noise = float(rng.uniform(0.0, 1e-5))
    y = quantum * np.round((x - x[0] + rng.normal(0.0, noise, x.shape)) / quantum)
    return StudentRecord(t, y, (*truth[:-1], last), both, rate_hz, events, touches,
                         float(np.hypot(noise, quantum / np.sqrt(12.0))))


def handling_record(seed: int, rate_hz: float, duration_s: float = 60.0) -> StudentRecord:
    """Nudges of the pulled cart and touches of the held one, for `duration_s`: no release."""
    return handling_records(seed, (rate_hz,), duration_s)[rate_hz]


def handling_records(seed: int, rates_hz: tuple[float, ...], duration_s: float = 60.0
                     ) -> dict[float, StudentRecord]:
    """`handling_record(seed, r, duration_s)` for each rate r, from one simulation."""
    rng = np.random.default_rng(seed)
    pulled = int(rng.integers(0, 2))
    touches: list[tuple[float, float, float, bool]] = []
    plan: list[tuple[str, float, dict[str, float]]] = []
    cursor = float(rng.uniform(0.5, 1.5))
    while cursor < duration_s - 2.0:
        if rng.random() < 0.5:
            d = float(rng.uniform(0.2, 0.5))
            height = float(rng.choice([-1, 1]) * rng.uniform(2e-3, 8e-3))
            plan.append(("nudge", cursor, {"duration": d, "height": height}))
        else:
            d = float(rng.uniform(0.3, 0.6))
            touches.append((cursor, d, float(rng.choice([-1, 1]) * rng.uniform(3e-3, 8e-3)), bool(rng.random() < 0.5)))
        cursor += d + float(rng.uniform(1.0, 4.0))
    plan.append(("end", duration_s, {}))
    rig, _wn = _rig(rng, pulled, False, touches)
    end = duration_s
    t, grids = _grids(end, rates_hz)
    x = np.full((t.size, 2), np.nan)
    z = np.zeros(4)
    clock = 0.0
    for kind, start, spec in plan:
        inside = (t >= clock) & (t < start) if start < end else (t >= clock)
        seg, ends = simulate(rig, [Phase(clock, start)], t[inside], z)
        x[inside], z, clock = seg, ends[-1], start
        if kind == "end":
            break
        traj = _from(float(z[pulled]), _bump(start, spec["duration"], spec["height"], back=True))
        inside = (t >= start) & (t < start + spec["duration"])
        seg, ends = simulate(rig, [Phase(start, start + spec["duration"], {pulled: traj})], t[inside], z)
        x[inside], z, clock = seg, ends[-1], start + spec["duration"]
    return {rate_hz: StudentRecord(t_r, (1.0 / 56000.0) * np.round((x_r - x_r[0]) * 56000.0), (), False,
                                   rate_hz, ("handling",))
            for rate_hz, t_r in grids.items() for x_r in (_on_grid(t, x, t_r),)}
