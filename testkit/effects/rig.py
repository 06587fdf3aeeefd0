"""The carts as a mechanical system, written from Newton's law (independent of `ident`).

Masses m_i (kg) joined by springs (to each other or to the wall) and viscous dampers to
ground. With x the displacements from the mechanical rest (m) and v = x' (m/s):

    m_i x_i'' = -(K x)_i - (C v)_i - Σ_s ±k_s γ e_s³ - m_i κ_i x_i³ - m_i q_i v_i |v_i|
                + k_h (w(t) - x_i) + c_h (w'(t) - v_i)   [a hand spring on mass i]
                - m_i f_i sign(v_i)                       [dry friction while slipping]

every spring s (stiffness k_s, extension e_s = x_i - x_j, or x_i for a spring to the wall) may
pull with k_s (e_s + γ e_s³): γ (1/m²) > 0 hardening, < 0 softening; κ_i (1/(m² s²)) is a
cubic restoring term of mass i about its rest (a nonlinear guide or ground spring); q_i (1/m) quadratic
drag, f_i (m/s²) kinetic Coulomb friction; a mass at rest stays stuck while the rest of its
force per mass stays within the static level s_i ≥ f_i. A hand spring (k_h, c_h) ties a held
cart to where the hand is, w(t): the hand holds it loosely, so it follows the other cart weakly
and wanders with the hand.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
#: position (m) and velocity (m/s) of something the hand moves, at time t (s)
Trajectory = Callable[[float], tuple[float, float]]


@dataclass(frozen=True)
class HandSpring:
    """Mass `index` tied to the hand's position `target(t)` by `stiffness` (N/m) and `damping` (N·s/m)."""

    index: int
    stiffness: float
    damping: float
    target: Trajectory


@dataclass(frozen=True)
class Rig:
    """The mechanical system; arrays have one entry per mass (see the module docstring)."""

    masses: FloatArray
    stiffness: FloatArray
    damping: FloatArray
    cubic: tuple[tuple[int, int | None, float], ...]
    cubic_per_mass: FloatArray
    drag: FloatArray
    kinetic: FloatArray
    static: FloatArray
    hands: tuple[HandSpring, ...] = field(default=())

    @property
    def n(self) -> int:
        return int(self.masses.size)

    def accel(self, t: float, x: FloatArray, v: FloatArray) -> FloatArray:
        """Every force but dry friction, per unit mass (m/s²), shape (n,)."""
        force = -self.stiffness @ x - self.damping @ v
        for i, j, k_gamma in self.cubic:     # k γ e³ (N) of a spring with extension e
            pull = k_gamma * (x[i] - (0.0 if j is None else x[j])) ** 3
            force[i] -= pull
            if j is not None:
                force[j] += pull
        for hand in self.hands:
            w, w_dot = hand.target(t)
            force[hand.index] += hand.stiffness * (w - x[hand.index]) + hand.damping * (w_dot - v[hand.index])
        return np.asarray(force / self.masses - self.cubic_per_mass * x ** 3 - self.drag * v * np.abs(v))

    def linear_matrix(self) -> FloatArray:
        """A of z' = A z for z = (x, v), the linear part with the hands' springs (2n, 2n)."""
        n = self.n
        k = self.stiffness.copy()
        c = self.damping.copy()
        for hand in self.hands:
            k[hand.index, hand.index] += hand.stiffness
            c[hand.index, hand.index] += hand.damping
        m_inv = np.diag(1.0 / self.masses)
        return np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ k, -m_inv @ c]])


def stiffness_matrix(n: int, springs: Sequence[tuple[int, int | None, float]]) -> FloatArray:
    """K (n, n) from springs (i, j, k): k (N/m) between masses i and j, or to the wall when j is None."""
    out = np.zeros((n, n))
    for i, j, k in springs:
        out[i, i] += k
        if j is not None:
            out[j, j] += k
            out[i, j] -= k
            out[j, i] -= k
    return out


def make_rig(masses: Sequence[float], springs: Sequence[tuple[int, int | None, float]],
             dampers: Sequence[float], *, drag: Sequence[float] | None = None,
             kinetic: Sequence[float] | None = None, static: Sequence[float] | None = None,
             cubic_rel: float = 0.0, cubic_per_mass: Sequence[float] | None = None,
             hands: Sequence[HandSpring] = ()) -> Rig:
    """A rig with dampers to ground (N·s/m per mass); per-mass drag (1/m), kinetic and static
    friction (m/s², static raised to at least kinetic) and cubic terms κ_i (1/(m² s²)) default to
    zero; `cubic_rel` γ (1/m²) acts on every spring given."""
    m = np.asarray(masses, dtype=np.float64)
    n = m.size

    def per_mass(value: Sequence[float] | None) -> FloatArray:
        return np.zeros(n) if value is None else np.asarray(value, dtype=np.float64).reshape(n)

    kin = per_mass(kinetic)
    cubic = tuple((i, j, k * cubic_rel) for i, j, k in springs) if cubic_rel else ()
    return Rig(m, stiffness_matrix(n, springs), np.diag(np.asarray(dampers, dtype=np.float64)),
               cubic, per_mass(cubic_per_mass), per_mass(drag), kin, np.maximum(per_mass(static), kin), tuple(hands))
