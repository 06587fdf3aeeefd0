"""Issue-11 families the first red team did not draw (issue 11 items 3 and 6), from the physics.

- `two_cart_coulomb_y12`: the chain with dry friction on both carts, read through BOTH encoders
  (lab case 3: cart 1 pulled, cart 2 held at its rest, both let go; or cart 1 flicked);
  `--carts 2`, both frictions in m/s² are identifiable.
- `coupled_span` (in `cases11._coupled`): the second mass 0.03–1.5 × the cart's (log-uniform) on a
  spring 0.3–2 k, pinned by a spring 0.2–20 × the coupling (log-uniform): a light stiff mass to a
  partly pinned cart of comparable mass.
- `quantization_edges`: a linear cart read on a lattice of exactly 10 µm (even seeds) or 2 mm
  (odd seeds), noise before it (the readings on the lattice exactly) or after it.
- `coulomb+force_pulse`: a cart with viscous and dry friction at rest, pushed by a motor
  `F = G u(t)`, `u` a rectangular duty pulse (200–800 counts, 3–6 s, switched at a sample and
  held to the next, as the controller logs what it applies) written as an `effort` column; the
  step it gives is 1–4 cm. `ident diagnose --input effort`: dry friction, no mode.
- `coulomb_rate_only`: the `coulomb` family's physics written without a time column;
  `ident diagnose --rate-hz R`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from cases11 import Case, _common, _finish, _one_cart, _rng, _two_cart
from physics import Cart, Chain, Simulator

FAMILIES_B = ("two_cart_coulomb_y12", "coupled_span", "quantization_edges", "coulomb+force_pulse",
              "coulomb_rate_only")

EXPECTED_B: dict[str, tuple[str, ...]] = {
    "two_cart_coulomb_y12": ("coulomb_friction",), "coupled_span": ("coupled_mode",),
    "quantization_edges": ("quantization",), "coulomb+force_pulse": ("coulomb_friction",),
    "coulomb_rate_only": ("coulomb_friction",),
}


def make_case_b(family: str, seed: int) -> Case:
    """Draw and simulate one case of a widened family (FAMILIES_B but `coupled_span`)."""
    rng = _rng(family, seed)
    p = _common(rng)
    p["family"] = family
    if family == "two_cart_coulomb_y12":
        return _two_cart(family, seed, rng, p, both_encoders=True)
    if family == "quantization_edges":
        p["quantum_m"] = 1e-5 if seed % 2 == 0 else 2e-3
        return _one_cart(family, seed, rng, p)
    if family == "coulomb+force_pulse":
        return _force_pulse(family, seed, rng, p)
    if family == "coulomb_rate_only":
        case = _one_cart("coulomb", seed, rng, p)  # its own draws; written without time by run11
        case.family = family
        return case
    raise ValueError(f"family: expected one of {FAMILIES_B}, got {family!r}")


def _force_pulse(family: str, seed: int, rng: np.random.Generator, p: dict[str, Any]) -> Case:
    """One cart at rest, a motor duty pulse u (counts) pushing it with G u newtons."""
    m, k = p["m"], p["k"]
    wn = np.sqrt(k / m)
    step = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.01, 0.04))  # G U / k
    duty = float(np.round(rng.uniform(200, 800)))
    gain = k * step / duty  # N per count
    dt = 1.0 / p["rate_hz"]
    # the duty switches at a sample (the controller applies what it logs, held to the next sample)
    t1 = float(np.ceil(rng.uniform(1.0, 3.0) / dt) * dt)
    t2 = float(t1 + np.ceil(rng.uniform(3.0, 6.0) / dt) * dt)
    p["duration_s"] = t2 + rng.uniform(3.0, 6.0)
    n_cycles = rng.uniform(4.0, 25.0)
    fk = k * abs(step) / (4 * n_cycles)
    cart = Cart(m=m, c=2 * p["zeta"] * np.sqrt(k * m), fk=fk, fs=fk * rng.uniform(1.0, 1.5))
    chain = Chain([cart], k1=k)
    t = np.arange(0.0, p["duration_s"], dt)
    t1, t2 = float(t[np.argmin(np.abs(t - t1))]), float(t[np.argmin(np.abs(t - t2))])  # the grid's own instants
    sim = Simulator(chain, np.zeros(1), np.zeros(1), 0.0)
    x = np.full((len(t), 1), np.nan)
    for t_end, force in ((t1, 0.0), (t2, gain * duty), (float(t[-1]) + 1e-9, 0.0)):  # the pulse: three runs
        cart.force = force
        seg = sim.run(t_end, t)
        x = np.where(np.isnan(x), seg, x)
    u = np.where((t >= t1) & (t < t2), duty, 0.0)
    p.update(kind="force", wn=float(wn), coulomb_accel_m_s2=fk / m, coulomb_cycles=n_cycles, fk_n=fk,
             fs_n=cart.fs, pulse_on_s=t1, pulse_off_s=t2, duty=duty, gain_n_per_count=gain,
             force_step_m=step, release_time_s=float(t1))
    case = _finish(family, seed, rng, p, t, x, [0])
    case.truth.pop("jump_snr", None)
    case.u = u
    return case
