"""The linear baseline and its physical extensions, each a model of its own.

Parameter vector (one row of a (P, p) array, so a Jacobian is one batched simulation):

    linear (chain.LINEAR_NAMES) | x0_i (m) | v0_i (m/s) | rest_i (m) | effect parameters

with i over the carts, the state (x0, v0) at the window start τ = 0 and rest the spring
equilibrium (the step, when `--step` is not given). Effect parameters:

    none               -
    coulomb_friction   f_i = coulomb_accel_m_s2[_cart2]   (friction force / mass, per cart)
    quadratic_drag     drag_per_m             (c_q / m, the same on every cart)
    cubic_stiffness    cubic_per_m2_s2        (k3 / m on each cart's x_i - rest_i)
    coupled_mode       mode_hz, mode_decay_1_s, mode_cos_m_j, mode_sin_m_j (per output j):
                       + e^{-σ τ}(a_j cos 2π f τ + b_j sin 2π f τ) added to output j
    quantization       quantum_m, lattice_offset_m, quantization_blur: the expected reading
                       E[offset + q·round((x + e - offset)/q)], e ~ N(0, (b q)²), a smoothed
                       staircase; b -> 0 is the bare encoder, b ≈ 0.45 is nearly the identity,
                       so the linear model is nested and b absorbs jitter and model error

The model predicts positions (P, N, carts) on τ_k = k·dt. No fitting and no I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.special
from numpy.typing import NDArray

from ident.physics.chain import LINEAR_NAMES
from ident.physics.free import NonlinearTerms, simulate_free

FloatArray = NDArray[np.float64]

EFFECTS: tuple[str, ...] = ("coulomb_friction", "quadratic_drag", "cubic_stiffness",
                            "quantization", "coupled_mode")


def state_names(carts: int) -> tuple[str, ...]:
    idx = range(1, carts + 1)
    return (tuple(f"x0_{i}_m" for i in idx) + tuple(f"v0_{i}_m_s" for i in idx)
            + tuple(f"rest_{i}_m" for i in idx))


def effect_names(effect: str, carts: int) -> tuple[str, ...]:
    if effect == "coulomb_friction":
        return ("coulomb_accel_m_s2",) + (("coulomb_accel_m_s2_cart2",) if carts == 2 else ())
    if effect == "quadratic_drag":
        return ("drag_per_m",)
    if effect == "cubic_stiffness":
        return ("cubic_per_m2_s2",)
    if effect == "coupled_mode":
        return ("mode_hz", "mode_decay_1_s", *(f"mode_cos_m_{j}" for j in range(1, carts + 1)),
                *(f"mode_sin_m_{j}" for j in range(1, carts + 1)))
    if effect == "quantization":
        return ("quantum_m", "lattice_offset_m", "quantization_blur")
    return ()


@dataclass(frozen=True)
class ModelSpec:
    """A model: its effect, cart count and parameter names; `fixed` maps index -> value."""

    effect: str
    carts: int
    fixed: dict[int, float] = field(default_factory=dict)

    @property
    def names(self) -> tuple[str, ...]:
        return LINEAR_NAMES[self.carts] + state_names(self.carts) + effect_names(self.effect, self.carts)

    @property
    def n_linear(self) -> int:
        return len(LINEAR_NAMES[self.carts])

    @property
    def n_effect(self) -> int:
        return len(effect_names(self.effect, self.carts))

    def predict(self, theta: FloatArray, dt: float, n_samples: int) -> FloatArray:
        """Positions (P, N, carts) for parameter rows `theta` (P, p)."""
        c, nl = self.carts, self.n_linear
        lin = theta[:, :nl]
        x0 = theta[:, nl:nl + c]
        v0 = theta[:, nl + c:nl + 2 * c]
        rest = theta[:, nl + 2 * c:nl + 3 * c]
        extra = theta[:, nl + 3 * c:]
        z0 = np.concatenate([x0 - rest, v0], axis=1)
        terms = self._terms(extra, lin)
        z = simulate_free(lin, z0, dt, n_samples, c, terms)
        x = z + rest[:, None, :]
        if self.effect == "coupled_mode":
            x = x + _extra_mode(extra, dt, n_samples, c)
        elif self.effect == "quantization":
            x = smoothed_staircase(x, extra[:, 0], extra[:, 1], extra[:, 2])
        return x

    def _terms(self, extra: FloatArray, lin: FloatArray) -> NonlinearTerms:
        c = self.carts
        if self.effect == "coulomb_friction":
            return NonlinearTerms(friction_m_s2=np.abs(extra[:, :c]))
        if self.effect == "quadratic_drag":
            return NonlinearTerms(drag_per_m=np.repeat(extra[:, :1], c, axis=1))
        if self.effect == "cubic_stiffness":
            # κ = wn² γ for one cart (per cart deviation); γ relative for the chain
            kt0 = lin[:, 0] ** 2 if c == 1 else np.ones(lin.shape[0])
            return NonlinearTerms(cubic_per_m2=extra[:, 0] / kt0)
        return NonlinearTerms()


def smoothed_staircase(x: FloatArray, q: FloatArray, offset: FloatArray, blur: FloatArray) -> FloatArray:
    """E[offset + q round((x + e - offset)/q)], e ~ N(0, (b q)²); x (P, N, c), q/offset/b (P,).

    With r = (x - offset)/q = n + φ (0 ≤ φ < 1): E = n + Σ_j Φ((φ - j + ½)/b) - Σ_j Φ((-φ - j - ½)/b),
    j = 1, 2 and j = 0, 1 (terms further out are below 1e-6 for b ≤ 0.5).
    """
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


def _extra_mode(extra: FloatArray, dt: float, n_samples: int, carts: int) -> FloatArray:
    """e^{-σ τ}(a_j cos ωτ + b_j sin ωτ) per output: (P, N, carts)."""
    tau = dt * np.arange(n_samples)
    w = 2 * np.pi * extra[:, 0][:, None]
    env = np.exp(-extra[:, 1][:, None] * tau[None, :])
    cos, sin = env * np.cos(w * tau), env * np.sin(w * tau)
    a = extra[:, 2:2 + carts]
    b = extra[:, 2 + carts:2 + 2 * carts]
    out: FloatArray = cos[:, :, None] * a[:, None, :] + sin[:, :, None] * b[:, None, :]
    return out
