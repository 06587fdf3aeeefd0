"""The linear baseline and its physical extensions: one model may carry several effects.

Parameter vector (one row of a (P, p) array, so a Jacobian is one batched simulation):

    linear (chain.LINEAR_NAMES) | x0_i (m) | v0_i (m/s) | rest_i (m) | input gains | effects

with i over the carts, the state (x0, v0) at the window start τ = 0, rest the spring
equilibrium, one gain per cart for a measured force input (`input_gain_i`, m/s² per unit
of the input column, only with `--input`), then each effect's block in `EFFECTS` order:

    coulomb_friction   F_i = coulomb_accel_m_s2[_cart2]   (kinetic friction force / mass)
    presliding         presliding_per_s2 σ: the friction is Dahl's (w' = σ(v - |v| w/F));
                       only on top of coulomb_friction
    static_friction    static_friction_ratio[_cart2] r_i ≥ 1: a cart at rest breaks away only
                       when the pull exceeds r_i F_i (kinetic F_i), one ratio per cart (two
                       carts rub on their own surfaces); on top of coulomb_friction, not
                       with presliding (Dahl friction has no stick)
    quadratic_drag     drag_per_m             (drag / m, the same on every cart)
    cubic_stiffness    cubic_per_m2_s2 κ: a_i = -κ (x_i - rest_i)³ on every cart (one cart:
                       a spring k (e + γ e³) with κ = wn² γ)
    held_cart_motion   held_cart_gain_per_s2 β: a = β (u_h(τ) - u_h(0)), u_h the held cart's
                       measured position (the spring between the carts, k2/m)
    rest_drift         drift_spacing_s (fixed), drift_knot_j_m r_j: one cart's rest moves by
                       r(τ) = Σ_j r_j B_j(τ), a slow cubic B-spline (`drift`): a = wn² r(τ), an
                       unmeasured held cart's wander
    coupled_mode       mode_hz, mode_decay_1_s, mode_cos_m_j, mode_sin_m_j (per output j):
                       + e^{-σ τ}(a_j cos 2π f τ + b_j sin 2π f τ) added to output j
    quantization       quantum_m, lattice_offset_m, quantization_blur: the expected reading
                       E[offset + q·round((x + e - offset)/q)], e ~ N(0, (b q)²), a smoothed
                       staircase (b -> 0 the bare encoder, b ≈ 0.45 nearly the identity)

The model predicts the measured positions (P, N, outputs) on τ_k = k·dt: every cart, or cart 1
only when two carts are read through one encoder (then cart 2's rest is not observable and is
held at 0). No fitting and no I/O here.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ident.physics.chain import LINEAR_NAMES
from ident.physics.free import NonlinearTerms, simulate_free

FloatArray = NDArray[np.float64]

#: Canonical order of the effect blocks in a parameter vector.
EFFECTS: tuple[str, ...] = ("coulomb_friction", "presliding", "static_friction", "quadratic_drag", "cubic_stiffness",
                            "held_cart_motion", "rest_drift", "coupled_mode", "quantization")


def state_names(carts: int) -> tuple[str, ...]:
    idx = range(1, carts + 1)
    return (tuple(f"x0_{i}_m" for i in idx) + tuple(f"v0_{i}_m_s" for i in idx)
            + tuple(f"rest_{i}_m" for i in idx))


def effect_names(effect: str, carts: int, outputs: int | None = None, knots: int = 0) -> tuple[str, ...]:
    """Parameter names of `effect` for `carts` carts seen through `outputs` encoders (`knots`:
    the rest drift's spline functions)."""
    outputs = carts if outputs is None else outputs
    if effect == "coulomb_friction":
        return ("coulomb_accel_m_s2",) + (("coulomb_accel_m_s2_cart2",) if carts == 2 else ())
    if effect == "presliding":
        return ("presliding_per_s2",)
    if effect == "static_friction":
        return ("static_friction_ratio",) + (("static_friction_ratio_cart2",) if carts == 2 else ())
    if effect == "quadratic_drag":
        return ("drag_per_m",)
    if effect == "cubic_stiffness":
        return ("cubic_per_m2_s2",)
    if effect == "held_cart_motion":
        return ("held_cart_gain_per_s2",)
    if effect == "rest_drift":
        return ("drift_spacing_s", *(f"drift_knot_{j}_m" for j in range(1, knots + 1)))
    if effect == "coupled_mode":
        return ("mode_hz", "mode_decay_1_s", *(f"mode_cos_m_{j}" for j in range(1, outputs + 1)),
                *(f"mode_sin_m_{j}" for j in range(1, outputs + 1)))
    if effect == "quantization":
        return ("quantum_m", "lattice_offset_m", "quantization_blur")
    return ()


@dataclass(frozen=True)
class ModelSpec:
    """A model: its effects (in `EFFECTS` order), cart count, measured inputs and parameter
    names; `fixed` maps parameter name -> value; `inputs` (N, m) force inputs held over each
    step and switching within it at `input_switch` (N, m) (`ident.physics.free.switched_input`),
    `held` (N,) the held cart's measured motion from its first sample, `drift` (N, K) the rest
    drift's spline basis (all on the work grid); `onset` the work sample where the carts begin
    to move (a forced window still until its input acts: a coupled mode rings from there)."""

    effects: tuple[str, ...]
    carts: int
    fixed: dict[str, float] = field(default_factory=dict)
    inputs: FloatArray | None = None
    held: FloatArray | None = None
    outputs: int = 0
    drift: FloatArray | None = None
    input_switch: FloatArray | None = None
    onset: int = 0

    @property
    def observed(self) -> int:
        """Measured outputs: carts 1..observed (two carts through one encoder: 1)."""
        return self.outputs or self.carts

    def with_effect(self, effect: str) -> ModelSpec:
        effects = tuple(e for e in EFFECTS if e in self.effects or e == effect)
        return dataclasses.replace(self, effects=effects, fixed=dict(self.fixed))

    def cut(self, n: int) -> ModelSpec:
        """The same model on the first `n` work samples (its measured inputs cut)."""
        return dataclasses.replace(self, inputs=None if self.inputs is None else self.inputs[:n],
                                   input_switch=None if self.input_switch is None else self.input_switch[:n],
                                   held=None if self.held is None else self.held[:n],
                                   drift=None if self.drift is None else self.drift[:n])

    def names_of(self, effect: str) -> tuple[str, ...]:
        """Parameter names of `effect` in this model."""
        return effect_names(effect, self.carts, self.observed, 0 if self.drift is None else self.drift.shape[1])

    @property
    def n_inputs(self) -> int:
        return 0 if self.inputs is None else int(self.inputs.reshape(self.inputs.shape[0], -1).shape[1])

    @property
    def names(self) -> tuple[str, ...]:
        inputs = tuple(f"input_gain_{i}_{q}" for q in range(1, self.n_inputs + 1) for i in range(1, self.carts + 1))
        return (LINEAR_NAMES[self.carts] + state_names(self.carts) + inputs
                + tuple(n for e in self.effects for n in self.names_of(e)))

    @property
    def n_linear(self) -> int:
        return len(LINEAR_NAMES[self.carts])

    @property
    def n_base(self) -> int:
        """Parameters before the first effect block."""
        return self.n_linear + 3 * self.carts + self.n_inputs * self.carts

    def block(self, effect: str) -> slice:
        """Where `effect`'s parameters sit in a parameter vector."""
        start = self.n_base
        for e in self.effects:
            size = len(self.names_of(e))
            if e == effect:
                return slice(start, start + size)
            start += size
        raise KeyError(effect)

    def predict(self, theta: FloatArray, dt: float, n_samples: int) -> FloatArray:
        """Measured positions (P, N, observed) for parameter rows `theta` (P, p)."""
        c, nl = self.carts, self.n_linear
        lin = theta[:, :nl]
        x0 = theta[:, nl:nl + c]
        v0 = theta[:, nl + c:nl + 2 * c]
        rest = theta[:, nl + 2 * c:nl + 3 * c]
        z0 = np.concatenate([x0 - rest, v0], axis=1)
        terms, u = self._terms(theta, lin, n_samples)
        x = simulate_free(lin, z0, dt, n_samples, c, terms, u, self._switch(u)) + rest[:, None, :]
        x = x[:, :, :self.observed]
        if "coupled_mode" in self.effects:
            x = x + _extra_mode(theta[:, self.block("coupled_mode")], dt, n_samples, self.observed, self.onset)
        if "quantization" in self.effects:
            q = theta[:, self.block("quantization")]
            x = smoothed_staircase(x, q[:, 0], q[:, 1], q[:, 2])
        return x

    def _switch(self, u: FloatArray | None) -> FloatArray | None:
        """Where each input column of `u` switches within a step: the measured force inputs
        (first) are held (`input_switch`); the held cart's motion and the rest drift are
        smooth, linear between samples (NaN)."""
        if u is None or self.input_switch is None:
            return None
        out = np.full(u.shape, np.nan)
        out[:, :self.n_inputs] = self.input_switch.reshape(u.shape[0], -1)
        return out

    def _terms(self, theta: FloatArray, lin: FloatArray, n: int) -> tuple[NonlinearTerms, FloatArray | None]:
        c, p = self.carts, theta.shape[0]
        kw: dict[str, FloatArray] = {}
        if "coulomb_friction" in self.effects:
            kw["friction_m_s2"] = np.abs(theta[:, self.block("coulomb_friction")])
        if "static_friction" in self.effects:
            ratio = np.maximum(theta[:, self.block("static_friction")], 1.0)
            kw["static_friction_m_s2"] = kw["friction_m_s2"] * ratio
        if "presliding" in self.effects:
            kw["presliding_per_s2"] = np.repeat(theta[:, self.block("presliding")], c, axis=1)
        if "quadratic_drag" in self.effects:
            kw["drag_per_m"] = np.repeat(theta[:, self.block("quadratic_drag")], c, axis=1)
        if "cubic_stiffness" in self.effects:
            kw["cubic_per_m2_s2"] = np.repeat(theta[:, self.block("cubic_stiffness")], c, axis=1)
        columns: list[FloatArray] = []
        gains: list[FloatArray] = []
        if self.n_inputs:
            assert self.inputs is not None
            columns.append(self.inputs.reshape(n, -1))
            start = self.n_linear + 3 * c
            g = theta[:, start:start + self.n_inputs * c].reshape(p, self.n_inputs, c)
            gains.append(np.transpose(g, (0, 2, 1)))
        if "held_cart_motion" in self.effects and self.held is not None:
            columns.append(self.held.reshape(n, 1))
            beta = theta[:, self.block("held_cart_motion")][:, 0]
            gains.append(np.repeat(beta[:, None, None], c, axis=1))
        if "rest_drift" in self.effects and self.drift is not None:   # one cart: a = wn² r(τ)
            columns.append(self.drift)
            knots = theta[:, self.block("rest_drift")][:, 1:]
            gains.append((lin[:, 0] ** 2)[:, None, None] * knots[:, None, :])
        if not columns:
            return NonlinearTerms(**kw), None
        kw["input_gain"] = np.concatenate(gains, axis=2)
        return NonlinearTerms(**kw), np.concatenate(columns, axis=1)


def smoothed_staircase(x: FloatArray, q: FloatArray, offset: FloatArray, blur: FloatArray) -> FloatArray:
    """E[offset + q round((x + e - offset)/q)], e ~ N(0, (b q)²); x (P, N, c), q/offset/b (P,).

    With r = (x - offset)/q = n + φ (0 ≤ φ < 1): E = n + Σ_j Φ((φ - j + ½)/b) - Σ_j Φ((-φ - j - ½)/b),
    j = 1, 2 and j = 0, 1 (terms further out are below 1e-6 for b ≤ 0.5).
    """
    import scipy.special  # deferred: keeps `import ident` fast
    qq = np.maximum(q, 1e-15)[:, None, None]
    off = offset[:, None, None]
    b = np.maximum(blur, 1e-6)[:, None, None]
    r = (x - off) / qq
    n = np.floor(r)
    phi = r - n
    level = n + sum(scipy.special.ndtr((phi - j + 0.5) / b) for j in (1, 2))
    level = level - sum(scipy.special.ndtr((-phi - j - 0.5) / b) for j in (0, 1))
    out: FloatArray = off + qq * level
    return out


def _extra_mode(extra: FloatArray, dt: float, n_samples: int, carts: int, onset: int = 0) -> FloatArray:
    """e^{-σ τ}(a_j cos ωτ + b_j sin ωτ) per output, τ from the work sample `onset` (0 before
    it): (P, N, carts)."""
    tau = dt * np.arange(-onset, n_samples - onset)
    w = 2 * np.pi * extra[:, 0][:, None]
    env = np.exp(-extra[:, 1][:, None] * tau[None, :])
    cos, sin = env * np.cos(w * tau), env * np.sin(w * tau)
    a = extra[:, 2:2 + carts]
    b = extra[:, 2 + carts:2 + 2 * carts]
    out: FloatArray = cos[:, :, None] * a[:, None, :] + sin[:, :, None] * b[:, None, :]
    out[:, :onset] = 0.0
    return out
