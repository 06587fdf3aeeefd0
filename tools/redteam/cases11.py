"""Issue-11 cases from the physics: one released cart (or a chain read through one encoder).

Each case is drawn from its own seed (`numpy.random.default_rng([crc32(family), seed])`), so
`make_case(family, seed)` is a reproduction. Ranges (issue 11 and the red-team brief):
mass 0.5–3 kg, k 100–800 N/m, ζ 0.005–0.05, encoder lattice 1e-5–2e-3 m (log-uniform),
noise before the lattice (σ 0.05–0.5 q) or after it (0.02–0.25 q), rate 50–1000 Hz
(log-uniform), 5–20 s, released from a hold (3–15 cm) or flicked from rest (3–5 cm in
0.10–0.20 s, let go at 80–100 % of the hand's path).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from physics import Cart, Chain, Simulator, quintic, wander

FAMILIES = (
    "none", "coulomb", "viscous+coulomb", "quadratic_drag", "cubic_hardening", "cubic_softening",
    "quantization", "coupled_light", "coupled_pinned", "coulomb+held_cart", "coulomb+quantization",
    "two_cart_coulomb_y1",
)

# the effect names (DESIGN.md) each family must show; quantization is added when material
EXPECTED: dict[str, tuple[str, ...]] = {
    "none": (), "coulomb": ("coulomb_friction",), "viscous+coulomb": ("coulomb_friction",),
    "quadratic_drag": ("quadratic_drag",), "cubic_hardening": ("cubic_stiffness",),
    "cubic_softening": ("cubic_stiffness",), "quantization": ("quantization",),
    "coupled_light": ("coupled_mode",), "coupled_pinned": ("coupled_mode",),
    "coulomb+held_cart": ("coulomb_friction", "held_cart_motion"),
    "coulomb+quantization": ("coulomb_friction", "quantization"),
    "two_cart_coulomb_y1": ("coulomb_friction",),
}


@dataclass
class Case:
    family: str
    seed: int
    t: np.ndarray  # (N,) s
    y: np.ndarray  # (N, n_columns) m, what the encoder(s) read
    x: np.ndarray  # (N, n_columns) m, the noiseless positions (same offsets)
    truth: dict[str, Any] = field(default_factory=dict)
    u: np.ndarray | None = None  # (N,) a recorded input column (a motor's duty), if any


def _rng(family: str, seed: int) -> np.random.Generator:
    return np.random.default_rng([zlib.crc32(family.encode()), seed])


def _common(rng: np.random.Generator) -> dict[str, Any]:
    rate = float(round(np.exp(rng.uniform(np.log(50), np.log(1000)))))
    q = float(np.exp(rng.uniform(np.log(1e-5), np.log(2e-3))))
    return {
        "m": rng.uniform(0.5, 3.0), "k": rng.uniform(100.0, 800.0), "zeta": rng.uniform(0.005, 0.05),
        "rate_hz": rate, "duration_s": rng.uniform(5.0, 20.0), "quantum_m": q,
        "noise_mode": str(rng.choice(["before", "after"])), "kind": str(rng.choice(["hold", "flick"])),
    }


def read_encoder(rng: np.random.Generator, x: np.ndarray, p: dict[str, Any]) -> np.ndarray:
    """Readings of positions x on a lattice q with noise before or after it."""
    q = p["quantum_m"]
    phase = rng.uniform(0, q)
    if p["noise_mode"] == "before":
        p["noise_rel"] = rng.uniform(0.05, 0.5)
        return q * np.round((x + phase + rng.normal(0, p["noise_rel"] * q, x.shape)) / q) - phase
    p["noise_rel"] = rng.uniform(0.02, 0.25)
    return q * np.round((x + phase) / q) - phase + rng.normal(0, p["noise_rel"] * q, x.shape)


def _release(sim_chain: Chain, rng: np.random.Generator, p: dict[str, Any], t: np.ndarray,
             cart: int, x_rest_other: float | None = None) -> tuple[np.ndarray, float]:
    """Hold or flick cart `cart`, release it, simulate to the end; positions (N, n), t_r."""
    n = len(sim_chain.carts)
    sgn = float(rng.choice([-1.0, 1.0]))
    x0 = np.zeros(n)
    if p["kind"] == "hold":
        d = p.setdefault("pull_m", rng.uniform(0.03, 0.15))
        t_r = rng.uniform(0.3, 2.0)
        x0[cart] = -sgn * d
        sim_chain.held = {cart: quintic(-1.0, -0.5, (x0[cart], 0, 0), (x0[cart], 0, 0))}
        if x_rest_other is not None:  # the other cart held at its own rest (lab case 3)
            sim_chain.held[1 - cart] = quintic(-1.0, -0.5, (0, 0, 0), (0, 0, 0))
        xr, vr = x0[cart], 0.0
    else:
        a = p.setdefault("flick_m", rng.uniform(0.03, 0.05))
        dur, frac = rng.uniform(0.10, 0.20), rng.uniform(0.8, 1.0)
        t_start = rng.uniform(0.3, 1.5)
        path = quintic(t_start, t_start + dur, (0, 0, 0), (sgn * a, 0, 0))
        t_r = t_start + frac * dur
        sim_chain.held = {cart: path}
        xr, vr = path(t_r)
    t_r = float(t_r + rng.uniform(0, 1) / p["rate_hz"]) if p["kind"] == "hold" else float(t_r)
    p.update(release_x_m=float(xr), release_v_m_s=float(vr))
    sim = Simulator(sim_chain, x0, np.zeros(n), float(t[0]))
    out = sim.run(t_r, t)
    hand = sim_chain.held[cart]
    a_hand = (hand(t_r - 1e-6)[1] - hand(t_r - 3e-6)[1]) / 2e-6
    sim_chain.held = {}
    p["release_accel_jump_m_s2"] = abs(a_hand - free_accel(sim_chain, sim, cart))
    rest = sim.run(float(t[-1]) + 1e-9, t)
    out = np.where(np.isnan(out), rest, out)
    return out, t_r


def free_accel(chain: Chain, sim: Simulator, cart: int) -> float:
    """Acceleration (m/s²) of `cart` just after the hand lets go, from the simulator's state."""
    f = chain.forces(sim.t, sim.x, sim.v)[cart]
    c = chain.carts[cart]
    if c.fk > 0 and abs(sim.v[cart]) > 1e-12:
        f -= c.fk * np.sign(sim.v[cart])
    elif c.fk > 0:
        f = 0.0 if abs(f) <= c.fs else f - c.fk * np.sign(f)
    return float(f / c.m)


def make_case(family: str, seed: int) -> Case:
    """Draw and simulate one case of `family` (one of FAMILIES)."""
    rng = _rng(family, seed)
    p = _common(rng)
    p["family"] = family
    builder = _two_cart if family in ("two_cart_coulomb_y1",) else (
        _coupled if family.startswith("coupled") else _held if family == "coulomb+held_cart" else _one_cart)
    return builder(family, seed, rng, p)


def _amp(p: dict[str, Any]) -> float:
    return p.get("pull_m", p.get("flick_m", 0.04))


def _one_cart(family: str, seed: int, rng: np.random.Generator, p: dict[str, Any]) -> Case:
    m, k = p["m"], p["k"]
    wn = np.sqrt(k / m)
    if family == "viscous+coulomb":
        p["zeta"] = rng.uniform(0.02, 0.05)
    if family == "coulomb+quantization":
        p["quantum_m"] = float(np.exp(rng.uniform(np.log(1e-4), np.log(2e-3))))
    cart = Cart(m=m, c=2 * p["zeta"] * np.sqrt(k * m))
    chain = Chain([cart], k1=k)
    t = np.arange(0.0, p["duration_s"], 1.0 / p["rate_hz"])
    amp = p.setdefault("pull_m", rng.uniform(0.03, 0.15)) if p["kind"] == "hold" else p.setdefault(
        "flick_m", rng.uniform(0.03, 0.05))
    if "coulomb" in family:
        n_cycles = rng.uniform(4.0, 25.0)
        cart.fk = k * amp / (4 * n_cycles)
        cart.fs = cart.fk * rng.uniform(1.0, 1.5)
        p.update(coulomb_cycles=n_cycles, fk_n=cart.fk, fs_n=cart.fs, coulomb_accel_m_s2=cart.fk / m)
    if family == "quadratic_drag":
        n_half = rng.uniform(3.0, 20.0)  # cycles to halve the amplitude: (8/3) q A n = 1
        cart.q = 3.0 / (8.0 * n_half * amp)
        p.update(drag_per_m=cart.q, drag_halving_cycles=n_half)
    if family.startswith("cubic"):
        ratio = rng.uniform(0.03, 0.30) * (1 if family == "cubic_hardening" else -1)
        chain.e1 = ratio / amp**2
        p.update(stiffness_change=ratio, cubic_per_m2_s2=k * chain.e1 / m)
    state = rng.bit_generator.state
    x, t_r = _release(chain, rng, p, t, 0)
    if family.startswith("cubic"):  # scale the coefficient to the swing the release really gave
        a_real = float(np.max(np.abs(x[t >= t_r, 0])))
        chain.e1 *= (amp / a_real) ** 2
        p.update(cubic_per_m2_s2=k * chain.e1 / m, swing_m=a_real)
        rng.bit_generator.state = state
        x, t_r = _release(chain, rng, p, t, 0)
    p.update(wn=float(wn), release_time_s=t_r)
    return _finish(family, seed, rng, p, t, x, [0])


def _coupled(family: str, seed: int, rng: np.random.Generator, p: dict[str, Any]) -> Case:
    """A main cart with a second mass on it: light and stiff, a partly pinned cart, or anything between."""
    m, k = p["m"], p["k"]
    for _ in range(1000):
        if family == "coupled_light":
            m2 = m * rng.uniform(0.03, 0.15)
            kc = k * rng.uniform(0.3, 2.0)
            kp = kc * rng.uniform(0.0, 0.5)
        elif family == "coupled_span":  # issue 11 item 3: light and stiff to comparable, partly pinned
            m2 = m * float(np.exp(rng.uniform(np.log(0.03), np.log(1.5))))
            kc = k * rng.uniform(0.3, 2.0)
            kp = kc * float(np.exp(rng.uniform(np.log(0.2), np.log(20.0))))
        else:
            m2 = m * rng.uniform(0.5, 1.5)
            kc = rng.uniform(100.0, 800.0)
            kp = kc * rng.uniform(2.0, 20.0)
        kk = np.array([[k + kc, -kc], [-kc, kc + kp]])
        w2, vec = np.linalg.eig(np.linalg.solve(np.diag([m, m2]), kk))
        order = np.argsort(w2)
        w = np.sqrt(w2[order])
        vec = vec[:, order]
        # modal share in cart 1 of a release from the hold (x2 at its static place)
        x0 = np.array([1.0, kc / (kc + kp)])
        coef = np.linalg.solve(vec, x0)
        share = np.abs(coef * vec[0]) / np.abs(coef * vec[0]).sum()
        main = int(np.argmax(share))
        other = 1 - main
        ok = (w[1] / w[0] >= 1.3 and w[other] / (2 * np.pi) < 0.4 * p["rate_hz"] / 2
              and share[other] >= 0.01)
        if ok:
            break
    c1 = 2 * p["zeta"] * np.sqrt(k * m)
    z2 = rng.uniform(0.005, 0.05)
    chain = Chain([Cart(m=m, c=c1), Cart(m=m2, c=2 * z2 * np.sqrt((kc + kp) * m2))], k1=k, k2=kc, k3=kp)
    t = np.arange(0.0, p["duration_s"], 1.0 / p["rate_hz"])
    p["kind"] = "hold"  # released from the hold: the other mass starts at its static place
    d = p.setdefault("pull_m", rng.uniform(0.03, 0.15))
    sgn = float(rng.choice([-1.0, 1.0]))
    x0 = np.array([-sgn * d, -sgn * d * kc / (kc + kp)])
    t_r = float(rng.uniform(0.3, 2.0) + rng.uniform(0, 1) / p["rate_hz"])
    chain.held = {0: quintic(-1, -0.5, (x0[0], 0, 0), (x0[0], 0, 0))}
    sim = Simulator(chain, x0, np.zeros(2), 0.0)
    sim.x[1] = x0[1]
    out = sim.run(t_r, t)
    chain.held = {}
    rest = sim.run(float(t[-1]) + 1e-9, t)
    x = np.where(np.isnan(out), rest, out)
    p["release_accel_jump_m_s2"] = abs((k * x0[0] + kc * (x0[0] - x0[1])) / m)
    p.update(m2=m2, kc=kc, kp=kp, mode_hz=float(w[other] / (2 * np.pi)), main_hz=float(w[main] / (2 * np.pi)),
             mode_share=float(share[other]), wn=float(w[main]), release_time_s=t_r, zeta2=z2)
    return _finish(family, seed, rng, p, t, x, [0])


def _held(family: str, seed: int, rng: np.random.Generator, p: dict[str, Any]) -> Case:
    """Cart 2 released with Coulomb; cart 1 held loosely by a hand that wanders 1.8–7 mm."""
    m2, kk = p["m"], p["k"]
    share = rng.uniform(0.3, 0.7)
    k2, k3 = kk * share, kk * (1 - share)
    m1, k1 = rng.uniform(0.5, 3.0), rng.uniform(100.0, 800.0)
    follow = rng.uniform(0.015, 0.06)  # static follow of the held cart: k2 / (k1 + k2 + kh)
    kh = k2 / follow - k1 - k2
    ch = 2 * 0.5 * np.sqrt(kh * m1)
    ptp = rng.uniform(100, 400) / 56000.0
    amp = p.setdefault("pull_m", rng.uniform(0.03, 0.15)) if p["kind"] == "hold" else p.setdefault(
        "flick_m", rng.uniform(0.03, 0.05))
    n_cycles = rng.uniform(4.0, 25.0)
    fk = kk * amp / (4 * n_cycles)
    c1 = Cart(m=m1, c=0.5, kh=kh, ch=ch, h=wander(rng, ptp))
    c2 = Cart(m=m2, c=2 * p["zeta"] * np.sqrt(kk * m2), fk=fk, fs=fk * rng.uniform(1.0, 1.5))
    chain = Chain([c1, c2], k1=k1, k2=k2, k3=k3)
    t = np.arange(0.0, p["duration_s"], 1.0 / p["rate_hz"])
    x, t_r = _release(chain, rng, p, t, 1)
    p.update(wn=float(np.sqrt(kk / m2)), held_cart_gain_per_s2=k2 / m2, coulomb_accel_m_s2=fk / m2,
             coulomb_cycles=n_cycles, wander_ptp_m=ptp, follow=follow, m1=m1, k1=k1, k2=k2, k3=k3,
             release_time_s=t_r)
    return _finish(family, seed, rng, p, t, x, [0, 1])


def _two_cart(family: str, seed: int, rng: np.random.Generator, p: dict[str, Any],
              both_encoders: bool = False) -> Case:
    """Two carts, Coulomb (static 1–1.5 × kinetic) on both, read through cart 1's encoder only,
    or through both encoders."""
    m1, m2 = p["m"], rng.uniform(0.5, 3.0)
    k1, k2, k3 = (rng.uniform(100.0, 800.0) for _ in range(3))
    z1, z2 = p["zeta"], rng.uniform(0.005, 0.05)
    amp = p.setdefault("pull_m", rng.uniform(0.03, 0.15)) if p["kind"] == "hold" else p.setdefault(
        "flick_m", rng.uniform(0.03, 0.05))
    n1, n2 = rng.uniform(4.0, 25.0), rng.uniform(4.0, 25.0)
    fk1, fk2 = (k1 + k2) * amp / (4 * n1), k2 * amp / (4 * n2)
    chain = Chain([Cart(m=m1, c=2 * z1 * np.sqrt((k1 + k2) * m1), fk=fk1, fs=fk1 * rng.uniform(1.0, 1.5)),
                   Cart(m=m2, c=2 * z2 * np.sqrt((k2 + k3) * m2), fk=fk2, fs=fk2 * rng.uniform(1.0, 1.5))],
                  k1=k1, k2=k2, k3=k3)
    t = np.arange(0.0, p["duration_s"], 1.0 / p["rate_hz"])
    x, t_r = _release(chain, rng, p, t, 0, x_rest_other=0.0)
    p.update(m2=m2, k1=k1, k2=k2, k3=k3, coulomb_accel_m_s2=fk1 / m1, coulomb_accel_m_s2_cart2=fk2 / m2,
             release_time_s=t_r, zeta2=z2)
    p.pop("zeta")  # a chain has no single ζ to compare
    if both_encoders:
        return _finish(family, seed, rng, p, t, x, [0, 1])
    return _finish(family, seed, rng, p, t, x[:, :1], [0])


def _finish(family: str, seed: int, rng: np.random.Generator, p: dict[str, Any], t: np.ndarray,
            x: np.ndarray, cols: list[int]) -> Case:
    x = x[:, cols] if x.shape[1] > len(cols) else x
    x = x + rng.uniform(-0.01, 0.01, x.shape[1])  # the encoder's zero is wherever it was
    y = read_encoder(rng, x, p)
    moving = x[t >= p["release_time_s"]]
    rms = float(np.sqrt(np.mean((moving[:, -1] - moving[:, -1].mean()) ** 2)))
    p["lattice_worth_points"] = 100 * p["quantum_m"] / np.sqrt(12) / rms
    # what marks the instant: the jump of the acceleration moves the cart ½ Δa T² in a sample
    noise = p["quantum_m"] * np.sqrt(1 / 12 + p["noise_rel"] ** 2)
    if "release_accel_jump_m_s2" in p:
        p["jump_snr"] = 0.5 * p["release_accel_jump_m_s2"] / p["rate_hz"] ** 2 / noise
    clean = {key: (float(v) if isinstance(v, np.floating | float | int) else v) for key, v in p.items()}
    return Case(family, seed, t, y, x, clean)
