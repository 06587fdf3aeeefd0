"""Seeded draws of lab runs with hidden physical effects, over the issue's physical ranges.

Every run: a release at t_r ∈ [0.3, 1.5] s followed by 4–10 s of free response, sampled at
50–1000 Hz (log-uniform), white noise 5 µm–0.2 mm (log-uniform) unless the encoder lattice
is the effect. The release is a pull-hold-release (the cart held still at -d, d ∈ [0.05, 0.2] m
from rest, the record zeroed there) or a flick (from rest to |x1| ∈ [0.02, 0.06] m in
0.1–0.2 s, let go with a velocity of up to ±0.5 wn |x1|), half of each unless asked.
One cart: m ∈ [0.5, 1.5] kg, wn ∈ [5, 20] rad/s, ζ ∈ [0.005, 0.05]. Two carts
(wall –k1– m1 –k2– m2 –k3– wall): m_i ∈ [0.5, 1.5] kg, k_i ∈ [20, 120] N/m, ζ_i ∈ [0.005, 0.04];
with `wide_carts`, m_i ∈ [0.3, 3] kg and k_i ∈ [20, 1000] N/m (log-uniform: a light cart on a
stiff spring beside a heavy one, modes up to ~10 times apart).
Amplitudes below: A = √(x_r² + (v_r/wn)²) at the release (x_r from rest), wn the lowest mode.

Families (an effect, `none`, or a pair):
- coulomb_friction: kinetic f = r wn² A / 4, r ∈ [0.02, 0.2] (a cycle loses 2–20 % of A),
  static = f·[1, 1.5]; two carts: on cart 1, cart 2 or both, seen through both encoders or
  (`encoders=1`) cart 1's only (then cart 2's friction is scored as f2 / k2 in metres, the only
  form cart 1's reading fixes: `coulomb_cart2_per_coupling_m`);
- quadratic_drag: q = r·3/(4A), r ∈ [0.03, 0.15], the same per mass on every cart;
- cubic_stiffness: γ = ±r·8/(3A²), r ∈ [0.005, r_max] (hardening and softening: the
  frequency moves by about ±r at A); r_max = 0.05 by default, `cubic_r_max=CUBIC_R_MAX_FULL`
  (0.12) the physical range: the stiffness then changes by ±γA² up to 32 % at the swing, where a
  soft spring's restoring force k(e + γe³) still grows (|γ|A² < 1/3; the diagnosis' bench and
  tests use it; `ident.releases`' release tests keep 0.05: at 0.12 a strong cubic hold of theirs,
  seed 1959769723, is dated 8 samples late); one cart: its spring
  pulls k (e + γ e³), reported as κ = wn² γ (`cubic_per_m2_s2`); two carts: a = -κ (x_i - rest_i)³
  on each cart, κ = wn² γ (the diagnosis' documented two-cart effect), or with
  `cubic_law="springs"` every spring k (e + γ e³), reported as γ (`cubic_rel_per_m2`);
- quantization: the encoder reads Q·round(y/Q), Q ∈ [10 µm, 2 mm] (log-uniform), an exact
  lattice or with white noise of 2–30 % of Q added after it;
- coupled_mode: an extra mass behind the last cart, m_e/m ∈ [0.05, 1.5] (log-uniform: from a
  light mass on a stiff spring to a partly pinned second cart of comparable mass), its own
  frequency 1.6–4× wn, the coupling spring 5–70 % (log-uniform) of its total stiffness, ζ_e ∈
  [0.003, 0.03]; drawn again until that mode shows in the observed carts with ≥ 5× the noise
  and decays no faster than 2/s; `mode_hz` is its damped frequency;
- none: the linear carts;
- viscous+coulomb: one cart, ζ ∈ [0.02, 0.08] and Coulomb as above (ζ is scored too);
- coulomb+quantization: one cart, both as above;
- coulomb+held_cart: cart 2 released (Coulomb, ζ ∈ [0.005, 0.05]), cart 1 held by a loose hand
  (a hand spring stiff enough that cart 1 follows at 2–5 %, lagging 20–30 ms) that wanders by
  2–7 mm; both encoders recorded, a one-cart model asked for.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from testkit.effects import hand as hands
from testkit.effects.case import Case, Observed, Truth
from testkit.effects.integrate import Phase, simulate
from testkit.effects.rig import FloatArray, HandSpring, Rig, make_rig

SINGLE = ("none", "coulomb_friction", "quadratic_drag", "cubic_stiffness", "quantization", "coupled_mode")
PAIRS = ("viscous+coulomb", "coulomb+quantization", "coulomb+held_cart")
FAMILIES = SINGLE + PAIRS
NOISE_M = (5e-6, 2e-4)
#: an effect worth less than this many fit-% points is immaterial (listed, never the headline)
IMMATERIAL_POINTS = 0.05


def log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


@dataclass(frozen=True)
class Layout:
    """Masses (kg), springs (i, j or None for the wall, N/m) and dampers to ground (N·s/m) of
    the linear carts; `pulled`: the cart the hand releases; `observed`: the carts read by an
    encoder; `still`: carts held still at their rest until a pull-hold release."""

    masses: tuple[float, ...]
    springs: tuple[tuple[int, int | None, float], ...]
    dampers: tuple[float, ...]
    pulled: int = 0
    observed: tuple[int, ...] = (0,)
    still: tuple[int, ...] = ()

    def rig(self, effects: dict[str, Any]) -> Rig:
        return make_rig(self.masses, self.springs, self.dampers, **effects)


@dataclass(frozen=True)
class Release:
    """`hold`: the pulled cart still at x (= -d) until t_r; `flick`: from rest to x with v at t_r."""

    kind: str
    t_r: float
    x: float
    v: float
    duration: float = 0.0


@dataclass
class Spec:
    """Everything drawn for one run before it is simulated."""

    layout: Layout
    release: Release
    wn: float
    amplitude: float
    effects: dict[str, Any] = field(default_factory=dict)
    parameters: dict[str, float] = field(default_factory=dict)
    details: dict[str, float] = field(default_factory=dict)
    present: tuple[str, ...] = ()
    headline: str | None = None
    quantum: float | None = None
    model: tuple[int, ...] = (0,)

    @property
    def carts(self) -> int:
        return len(self.model)


def one_cart(rng: np.random.Generator, zeta: tuple[float, float] = (0.005, 0.05)) -> Layout:
    m, wn, z = rng.uniform(0.5, 1.5), rng.uniform(5.0, 20.0), rng.uniform(*zeta)
    return Layout((m,), ((0, None, wn * wn * m),), (2 * z * wn * m,))


#: Two carts' masses (kg) and springs (N/m) over a wider physical range (`wide=True`, log-uniform):
#: a light cart on a stiff spring beside a heavy one, modes up to ~10 times apart.
WIDE_MASSES = (0.3, 3.0)
WIDE_SPRINGS = (20.0, 1000.0)


def two_carts(rng: np.random.Generator, zeta: tuple[float, float] = (0.005, 0.04), wide: bool = False) -> Layout:
    if wide:
        m = np.exp(rng.uniform(np.log(WIDE_MASSES[0]), np.log(WIDE_MASSES[1]), 2))
        k = np.exp(rng.uniform(np.log(WIDE_SPRINGS[0]), np.log(WIDE_SPRINGS[1]), 3))
    else:
        m = rng.uniform(0.5, 1.5, 2)
        k = rng.uniform(20.0, 120.0, 3)
    z = rng.uniform(*zeta, 2)
    c = 2 * z * np.sqrt(np.array([k[0] + k[1], k[1] + k[2]]) * m)
    return Layout(tuple(float(v) for v in m), ((0, None, float(k[0])), (0, 1, float(k[1])), (1, None, float(k[2]))),
                  tuple(float(v) for v in c), 0, (0, 1), (1,))


def lowest_wn(rig: Rig) -> float:
    return float(np.min(np.abs(np.linalg.eigvals(rig.linear_matrix()))))


def draw_release(rng: np.random.Generator, kind: str | None, wn: float) -> Release:
    kind = kind or str(rng.choice(["hold", "flick"]))
    t_r = float(rng.uniform(0.3, 1.5))
    if kind == "hold":
        return Release("hold", t_r, -float(rng.uniform(0.05, 0.2)), 0.0)
    if kind != "flick":
        raise ValueError(f"release: expected 'hold' or 'flick', got {kind!r}")
    x1 = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.06))
    return Release("flick", t_r, x1, float(rng.uniform(-0.5, 0.5) * wn * abs(x1)), float(rng.uniform(0.1, 0.2)))


def base(rng: np.random.Generator, layout: Layout, kind: str | None) -> Spec:
    wn = lowest_wn(layout.rig({}))
    rel = draw_release(rng, kind, wn)
    return Spec(layout, rel, wn, float(np.hypot(rel.x, rel.v / wn)), model=layout.observed)


def layout_for(rng: np.random.Generator, carts: int | None, wide: bool = False) -> Layout:
    carts = carts or int(rng.integers(1, 3))
    if carts not in (1, 2):
        raise ValueError(f"carts: expected 1 or 2, got {carts}")
    return one_cart(rng) if carts == 1 else two_carts(rng, wide=wide)


# --- the effects -------------------------------------------------------------------------

def add_coulomb(rng: np.random.Generator, spec: Spec, on: tuple[int, ...]) -> None:
    n = len(spec.layout.masses)
    kinetic, static = np.zeros(n), np.zeros(n)
    for i in on:
        kinetic[i] = rng.uniform(0.02, 0.2) * spec.wn ** 2 * spec.amplitude / 4
        static[i] = kinetic[i] * rng.uniform(1.0, 1.5)
    spec.effects.update(kinetic=kinetic, static=static)
    names = ("coulomb_accel_m_s2", "coulomb_accel_m_s2_cart2")
    for k, i in enumerate(spec.model):
        spec.parameters[names[k]] = float(kinetic[i])
    for i in range(n):
        spec.details[f"static_accel_m_s2_mass{i + 1}"] = float(static[i])
    spec.present += ("coulomb_friction",)


def one_encoder_friction(spec: Spec) -> None:
    """Cart 2's friction seen through cart 1's encoder only: its force over the coupling
    spring's stiffness, f2 / k2 (m), replaces its m/s² (scaling cart 2's coordinate changes that
    and leaves cart 1's reading unchanged; f2 / k2 is the same in any scale). Cart 1's friction
    in the same terms, f1 / k2, and cart 2's m/s² are kept as details: the scales a zero friction
    is scored against."""
    k2 = spec.layout.springs[1][2]
    kinetic = spec.effects["kinetic"]
    spec.details["coulomb_accel_m_s2_cart2"] = spec.parameters.pop("coulomb_accel_m_s2_cart2")
    spec.parameters["coulomb_cart2_per_coupling_m"] = float(kinetic[1] * spec.layout.masses[1] / k2)
    spec.details["coulomb_cart1_per_coupling_m"] = float(kinetic[0] * spec.layout.masses[0] / k2)


def add_drag(rng: np.random.Generator, spec: Spec) -> None:
    q = rng.uniform(0.03, 0.15) * 3 / (4 * spec.amplitude)
    spec.effects["drag"] = np.full(len(spec.layout.masses), q)
    spec.parameters["drag_per_m"] = float(q)
    spec.present += ("quadratic_drag",)


#: The cubic spring's largest r (frequency change at the swing) by default and over the
#: physical range (module docstring).
CUBIC_R_MAX = 0.05
CUBIC_R_MAX_FULL = 0.12


def add_cubic(rng: np.random.Generator, spec: Spec, law: str = "carts", r_max: float = CUBIC_R_MAX) -> None:
    """One cart: its spring k (e + γ e³), reported as κ = wn² γ (a = -κ (x - rest)³). Two carts,
    `law="carts"`: a = -κ (x_i - rest_i)³ on each cart (the diagnosis' documented two-cart
    effect, so that its coefficient can be scored); `law="springs"`: every spring k (e + γ e³),
    reported as γ (`cubic_rel_per_m2`)."""
    r = rng.choice([-1.0, 1.0]) * rng.uniform(0.005, r_max)
    gamma = float(r * 8 / (3 * spec.amplitude ** 2))
    if spec.carts == 1 or law == "springs":
        spec.effects["cubic_rel"] = gamma
        name, value = ("cubic_per_m2_s2", spec.wn ** 2 * gamma) if spec.carts == 1 else ("cubic_rel_per_m2", gamma)
    elif law == "carts":
        spec.effects["cubic_per_mass"] = np.full(len(spec.layout.masses), spec.wn ** 2 * gamma)
        name, value = "cubic_per_m2_s2", spec.wn ** 2 * gamma
    else:
        raise ValueError(f"cubic law: expected 'carts' or 'springs', got {law!r}")
    spec.parameters[name] = float(value)
    spec.present += ("cubic_stiffness",)


def add_lattice(rng: np.random.Generator, spec: Spec) -> None:
    spec.quantum = log_uniform(rng, 1e-5, 2e-3)
    spec.parameters["quantum_m"] = spec.quantum
    spec.present += ("quantization",)


def mode_amplitudes(rig: Rig, z: FloatArray, observed: tuple[int, ...]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per oscillatory mode of the linear part (sorted by frequency): the largest amplitude (m) it
    has in the observed carts for the free response from state z (from rest), its damped
    frequency (Hz) and decay rate (1/s)."""
    lam, vec = np.linalg.eig(rig.linear_matrix())
    coef = np.linalg.solve(vec, z.astype(complex))
    upper = [k for k in range(lam.size) if lam[k].imag > 0]
    upper.sort(key=lambda k: lam[k].imag)
    amp = np.array([2 * np.max(np.abs(vec[list(observed), k] * coef[k])) for k in upper])
    return amp, np.array([lam[k].imag / (2 * np.pi) for k in upper]), np.array([-lam[k].real for k in upper])


def release_state(rig: Rig, spec: Spec) -> FloatArray:
    """The state at the release (used to judge which modes show): a pull-hold's static
    equilibrium under the hold; a flick's state where the hand lets go, simulated through the
    flick (a slow flick carries a stiffly coupled extra mass along and leaves its mode nearly
    unexcited: taking the others at rest there had counted a mode that never rang as shown)."""
    first = phases(spec, spec.release.t_r + 1.0)[0]
    z = initial_state(rig, first)
    if spec.release.kind == "flick":
        _, ends = simulate(rig, [first], np.array([first.start]), z)
        z = ends[0]
        z[spec.layout.pulled], z[rig.n + spec.layout.pulled] = spec.release.x, spec.release.v
    return z


def add_mode(rng: np.random.Generator, spec: Spec, noise: float) -> Spec:
    """An extra mass behind the last cart (see the module docstring), drawn until its mode shows.

    A slow flick can carry every drawn extra mass along without ringing it: after 500 draws the
    release becomes a pull-hold from the same position (the hold rings the mode: the extra mass
    rests under the hold and is let go with the cart)."""
    drawn = _draw_mode(rng, spec, noise)
    if drawn is None and spec.release.kind == "flick":
        held = Release("hold", spec.release.t_r, spec.release.x, 0.0)
        drawn = _draw_mode(rng, Spec(spec.layout, held, spec.wn, spec.amplitude, model=spec.model), noise)
    if drawn is None:
        raise RuntimeError("no visible coupled mode in 500 draws")
    return drawn


def _draw_mode(rng: np.random.Generator, spec: Spec, noise: float) -> Spec | None:
    """`add_mode`'s draws for the release of `spec`; None when no mode shows in 500."""
    lay = spec.layout
    last, e = spec.model[-1], len(lay.masses)
    for _ in range(500):
        m_e = log_uniform(rng, 0.05, 1.5) * lay.masses[last]
        w_e = rng.uniform(1.6, 4.0) * spec.wn
        k_total = w_e * w_e * m_e
        k_c = log_uniform(rng, 0.05, 0.7) * k_total
        c_e = 2 * rng.uniform(0.003, 0.03) * w_e * m_e
        new = Layout((*lay.masses, m_e), (*lay.springs, (last, e, k_c), (e, None, k_total - k_c)),
                     (*lay.dampers, c_e), lay.pulled, lay.observed, lay.still)
        drawn = Spec(new, spec.release, spec.wn, spec.amplitude, model=spec.model)
        rig = new.rig({})
        amp, hz, decay = mode_amplitudes(rig, release_state(rig, drawn), new.observed)
        weakest = int(np.argmin(amp))
        if amp[weakest] >= 5 * noise and decay[weakest] <= 2.0:
            drawn.parameters["mode_hz"] = float(hz[weakest])
            drawn.details.update(extra_mass_kg=m_e, extra_mode_amplitude_m=float(amp[weakest]),
                                 extra_mode_decay_1_s=float(decay[weakest]))
            drawn.present += ("coupled_mode",)
            return drawn
    return None


def held_cart(rng: np.random.Generator, kind: str | None, wide: bool = False) -> Spec:
    """Cart 2 released, cart 1 held by a loose, wandering hand (both encoders read)."""
    lay = two_carts(rng, (0.005, 0.05), wide)
    k2 = lay.springs[1][2]
    k_h = k2 / rng.uniform(0.02, 0.05)
    hand = HandSpring(0, k_h, k_h * rng.uniform(0.02, 0.03), hands.wander(rng, rng.uniform(2e-3, 7e-3)))
    lay = Layout(lay.masses, lay.springs, lay.dampers, pulled=1, observed=(0, 1), still=())
    effects: dict[str, Any] = {"hands": (hand,)}
    wn = lowest_wn(lay.rig(effects))
    rel = draw_release(rng, kind, wn)
    spec = Spec(lay, rel, wn, float(np.hypot(rel.x, rel.v / wn)), effects=effects, model=(1,))
    spec.details.update(hand_stiffness_n_m=k_h, hand_damping_n_s_m=hand.damping)
    return spec


def draw_spec(rng: np.random.Generator, family: str, carts: int | None, kind: str | None,
              encoders: int | None, noise: float, cubic_law: str = "carts",
              cubic_r_max: float = CUBIC_R_MAX, wide: bool = False) -> Spec:
    if family in ("viscous+coulomb", "coulomb+quantization"):
        spec = base(rng, one_cart(rng, (0.02, 0.08) if family == "viscous+coulomb" else (0.005, 0.05)), kind)
        add_coulomb(rng, spec, (0,))
        if family == "viscous+coulomb":
            m, c, k = spec.layout.masses[0], spec.layout.dampers[0], spec.layout.springs[0][2]
            spec.parameters["zeta"] = float(c / (2 * np.sqrt(k * m)))
        else:
            add_lattice(rng, spec)
        return spec
    if family == "coulomb+held_cart":
        spec = held_cart(rng, kind, wide)
        add_coulomb(rng, spec, (1,))
        spec.present += ("held_cart_motion",)
        # the held cart pulls the free one through the spring between them: a = β u_h, β = k2/m2
        spec.parameters["held_cart_gain_per_s2"] = spec.layout.springs[1][2] / spec.layout.masses[1]
        return spec
    spec = base(rng, layout_for(rng, carts, wide), kind)
    spec.headline = family
    if family == "coulomb_friction":
        on = (0,) if spec.carts == 1 else [(0,), (1,), (0, 1)][int(rng.integers(0, 3))]
        add_coulomb(rng, spec, on)
        if encoders == 1 and spec.carts == 2:
            spec.layout = Layout(spec.layout.masses, spec.layout.springs, spec.layout.dampers,
                                 0, (0,), spec.layout.still)
            one_encoder_friction(spec)
    elif family == "quadratic_drag":
        add_drag(rng, spec)
    elif family == "cubic_stiffness":
        add_cubic(rng, spec, cubic_law, cubic_r_max)
    elif family == "quantization":
        add_lattice(rng, spec)
    elif family == "coupled_mode":
        spec = add_mode(rng, spec, noise)
        spec.headline = family
    elif family != "none":
        raise ValueError(f"family: expected one of {', '.join(FAMILIES)}, got {family!r}")
    return spec


def initial_state(rig: Rig, phase: Phase) -> FloatArray:
    """Prescribed masses where the hand is; the others at their static equilibrium (linear springs)."""
    n = rig.n
    k = rig.stiffness.copy()
    for h in rig.hands:
        k[h.index, h.index] += h.stiffness
    x = np.zeros(n)
    fixed = sorted(phase.prescribed)
    for i in fixed:
        x[i] = phase.prescribed[i](phase.start)[0]
    free = [i for i in range(n) if i not in phase.prescribed]
    if free and fixed:
        x[free] = np.linalg.solve(k[np.ix_(free, free)], -k[np.ix_(free, fixed)] @ x[fixed])
    return np.concatenate([x, np.zeros(n)])


def phases(spec: Spec, end: float) -> list[Phase]:
    rel, lay = spec.release, spec.layout
    if rel.kind == "hold":
        held = {lay.pulled: hands.hold(rel.x)} | {i: hands.hold(0.0) for i in lay.still}
    else:
        held = {lay.pulled: hands.flick(rel.t_r - rel.duration, rel.t_r, rel.x, rel.v)}
    return [Phase(0.0, rel.t_r, held), Phase(rel.t_r, end)]


def make_case(seed: int, family: str | None = None, *, carts: int | None = None, release: str | None = None,
              encoders: int | None = None, rate_hz: float | None = None, record_s: float | None = None,
              encoder_m: float | None = None, cubic_law: str = "carts",
              cubic_r_max: float = CUBIC_R_MAX, wide_carts: bool = False) -> Case:
    """One run of `family` (drawn by the seed when None). `carts` (1, 2) and `release` ('hold',
    'flick') are drawn unless given; `encoders=1` reads only cart 1 of two carts with friction;
    `rate_hz` and `record_s` (the whole record's length) fix the sampling (speed measurements);
    `encoder_m` reads the noisy positions through an encoder of that count (m), as real rigs do
    (the ECP's 1/56000 m): a real but immaterial lattice, not one of the case's effects (a
    family with its own lattice keeps only that one); `cubic_law` and `cubic_r_max` see `add_cubic`;
    `wide_carts` draws two carts' masses and springs over `WIDE_MASSES` and `WIDE_SPRINGS`."""
    rng = np.random.default_rng(seed)
    family = family or str(rng.choice(FAMILIES))
    if family not in FAMILIES:
        raise ValueError(f"family: expected one of {', '.join(FAMILIES)}, got {family!r}")
    rate = log_uniform(rng, 50.0, 1000.0)
    length = float(rng.uniform(4.0, 10.0))
    rate = rate if rate_hz is None else rate_hz
    noise = log_uniform(rng, *NOISE_M)
    spec = draw_spec(rng, family, carts, release, encoders, noise, cubic_law, cubic_r_max, wide_carts)
    if record_s is not None:
        length = record_s - spec.release.t_r
    end = spec.release.t_r + length
    t = np.arange(round(end * rate)) / rate
    rig = spec.layout.rig(spec.effects)
    steps = phases(spec, end)
    x, _ = simulate(rig, steps, t, initial_state(rig, steps[0]))
    obs = list(spec.layout.observed)
    clean = x[:, obs] - x[0, obs]
    y, noise = sense(rng, clean, spec.quantum, noise)
    if encoder_m is not None and spec.quantum is None:
        y = encoder_m * np.round(y / encoder_m)
        spec.details["encoder_m"] = encoder_m
    details = dict(spec.details, wn_rad_s=spec.wn, amplitude_m=spec.amplitude, length_s=length,
                   release_x_m=spec.release.x, release_v_m_s=spec.release.v)
    immaterial: tuple[str, ...] = ()
    headline = spec.headline
    if spec.quantum is not None:
        free = int(np.searchsorted(t, spec.release.t_r))   # the free response: what a diagnosis fits
        details["lattice_points"] = lattice_points(clean[free:], y[free:], spec.quantum)
        if details["lattice_points"] < IMMATERIAL_POINTS:
            immaterial = ("quantization",)
            headline = "none" if headline == "quantization" else headline
    truth = Truth(family, headline, spec.present, dict(spec.parameters), spec.release.t_r,
                  spec.release.kind, rate, noise, clean, details, immaterial)
    return Case(seed, Observed(t, y, spec.carts), truth)


def lattice_points(clean: FloatArray, y: FloatArray, quantum: float) -> float:
    """What the lattice alone costs a perfect model, in fit-% points: 100 ‖Q·round(x/Q) - x‖ / ‖y - ȳ‖,
    over the free response from the release on (`make_case`): the points of the fit % a diagnosis
    reports (its window), not of the whole record, whose hold before a pull-hold release adds to
    ‖y - ȳ‖ (a 33 µm lattice worth 0.056 points of the free response counted 0.049 over the whole
    record, seed 675835176, and its diagnosis's 'material' was scored wrong)."""
    lattice = quantum * np.round(clean / quantum)
    return float(100.0 * np.linalg.norm(lattice - clean) / np.linalg.norm(y - y.mean(axis=0)))


def sense(rng: np.random.Generator, clean: FloatArray, quantum: float | None,
          noise: float) -> tuple[FloatArray, float]:
    """The encoder: white noise, or the lattice Q·round(y/Q) (exact, or noise of 2–30 % of Q after it)."""
    if quantum is None:
        return clean + rng.normal(0.0, noise, clean.shape), noise
    y = quantum * np.round(clean / quantum)
    after = 0.0 if rng.random() < 0.5 else quantum * rng.uniform(0.02, 0.3)
    return y + rng.normal(0.0, after, clean.shape) if after else y, after
