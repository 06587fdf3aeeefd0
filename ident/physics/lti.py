"""Hand-derived physical models of the lab's carts (numpy only; the simulated rig imports it).

Single cart (Part 1, the other cart pinned)
-------------------------------------------
Newton on the cart (mass m, kg) tied by a spring k (N/m) to an anchor at position r (m),
with viscous damping c (N·s/m) to ground:

    m x'' = -k (x - r) - c x'   ⇔   m x'' + c x' + k x = k r.

Laplace with zero initial conditions: (m s² + c s + k) X = k R, so

    G(s) = X/R = k / (m s² + c s + k) = wn² / (s² + 2 ζ wn s + wn²),
    wn = √(k/m) (rad/s),   ζ = c / (2 √(k m)),   DC gain G(0) = 1.

In the lab the cart is held at -d (zeroed frame: it reads 0 there) and released at t_r:
x'' + 2ζwn x' + wn² (x - d·H(t - t_r)) = 0, i.e. the same G(s) driven by r = d·H(t - t_r).

Two-cart chain (Part 1, both carts free)
----------------------------------------
`wall/anchor –k1– m1 –k2– m2 –k3– wall`, dampers c1, c2 from each cart to ground. With
x = (x1, x2) and the input entering as a force vector f·u:

    M x'' + C x' + K x = f u,   M = diag(m1, m2),   C = diag(c1, c2),
    K = [[k1 + k2, -k2], [-k2, k2 + k3]].

Laplace: Z(s) X = f U with Z(s) = M s² + C s + K, so X = adj(Z) f / det Z · U:

    det Z = (m1 s² + c1 s + k1 + k2)(m2 s² + c2 s + k2 + k3) - k2²,
    X1/U = [(m2 s² + c2 s + k2 + k3) f1 + k2 f2] / det Z,
    X2/U = [k2 f1 + (m1 s² + c1 s + k1 + k2) f2] / det Z.

Input structures (`f`):
- `release` (the lab, DESIGN.md): carts held at -d·e from rest and released, in the zeroed
  frame M x'' + C x' + K (x - e·r) = 0 with r = d·H(t - t_r), so f = K e. Pulling cart 1
  (e = (1, 0)): f = (k1 + k2, -k2), i.e. (k1 + k2)·0.15 on cart 1 and -k2·0.15 on cart 2; the
  carts settle at e·r (cart 1 at +0.15 m, cart 2 at 0). Then
  X1/R = [(m2 s² + c2 s + k2 + k3)(k1 + k2) - k2²] / det Z  (DC gain 1, relative degree 2),
  X2/R = -k2 (m1 s² + c1 s) / det Z                        (DC gain 0, relative degree 2).
- `anchor`: the far end of k1 moved by r: f = (k1, 0);
  X2/R = k2 k1 / det Z has relative degree 4 and cart 2 stays displaced at rest.
- `force`: a motor force u (N) on cart 1, as on the ECP-210: f = (1, 0).

State space x = (x1, x2, x1', x2'): A = [[0, I], [-M⁻¹K, -M⁻¹C]], B = [0; M⁻¹ f],
C = [I 0], D = 0. This module holds no fitting and no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentValueError

if TYPE_CHECKING:
    import control

FloatArray = NDArray[np.float64]
InputStructure = Literal["release", "anchor", "force"]


@dataclass(frozen=True)
class StateSpace:
    """Continuous-time `x' = A x + B u`, `y = C x + D u`; A (n, n), B (n, 1), C (p, n), D (p, 1)."""

    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray


@dataclass(frozen=True)
class Mode:
    """One oscillatory mode: natural frequency `wn` (rad/s), damping ratio `zeta` (-)."""

    wn: float
    zeta: float

    @property
    def pole(self) -> complex:
        """The upper-half-plane pole -ζ wn + j wn √(1 - ζ²)."""
        return complex(-self.zeta * self.wn, self.wn * np.sqrt(max(0.0, 1.0 - self.zeta ** 2)))


def modes_of(A: FloatArray) -> list[Mode]:
    """Modes of a state matrix, sorted by `wn`: one per complex pair or real pole.

    wn = |λ|, ζ = -Re λ / |λ|.
    """
    poles = np.linalg.eigvals(np.asarray(A, dtype=np.float64))
    kept = [p for p in poles if p.imag >= 0.0]
    kept.sort(key=abs)
    return [Mode(float(abs(p)), float(-p.real / abs(p)) if abs(p) > 0 else 1.0) for p in kept]


def transfer_functions(coefficients: list[tuple[FloatArray, FloatArray]]) -> list[control.TransferFunction]:
    """`control.TransferFunction` objects from (num, den) pairs (control imported lazily)."""
    import control

    return [control.tf(num, den) for num, den in coefficients]


def _positive(**values: float) -> None:
    for name, value in values.items():
        if not np.isfinite(value) or value <= 0.0:
            raise IdentValueError(name, "a positive finite number", value)


def _non_negative(**values: float) -> None:
    for name, value in values.items():
        if not np.isfinite(value) or value < 0.0:
            raise IdentValueError(name, "a non-negative finite number", value)


@dataclass(frozen=True)
class SingleCart:
    """`m x'' + c x' + k x = k r` (SI: kg, N·s/m, N/m); input r (m), output x (m)."""

    m: float
    c: float
    k: float

    def __post_init__(self) -> None:
        _positive(m=self.m, k=self.k)
        _non_negative(c=self.c)

    @classmethod
    def from_modal(cls, wn: float, zeta: float, m: float = 1.0) -> SingleCart:
        """The cart with natural frequency `wn`, damping `zeta` and mass `m`."""
        _positive(wn=wn, m=m)
        return cls(m=m, c=2.0 * zeta * wn * m, k=wn ** 2 * m)

    @property
    def wn(self) -> float:
        return float(np.sqrt(self.k / self.m))

    @property
    def zeta(self) -> float:
        return float(self.c / (2.0 * np.sqrt(self.k * self.m)))

    @property
    def dc_gain(self) -> float:
        return 1.0

    def state_space(self) -> StateSpace:
        """x = (position, velocity): A = [[0, 1], [-k/m, -c/m]], B = [0, k/m]ᵀ, C = [1, 0]."""
        A = np.array([[0.0, 1.0], [-self.k / self.m, -self.c / self.m]])
        B = np.array([[0.0], [self.k / self.m]])
        return StateSpace(A, B, np.array([[1.0, 0.0]]), np.zeros((1, 1)))

    def tf_coefficients(self) -> list[tuple[FloatArray, FloatArray]]:
        """[(num, den)] of G(s) = (k/m) / (s² + (c/m) s + k/m), highest power first."""
        return [(np.array([self.k / self.m]), np.array([1.0, self.c / self.m, self.k / self.m]))]

    def tf(self) -> list[control.TransferFunction]:
        return transfer_functions(self.tf_coefficients())

    def modes(self) -> list[Mode]:
        return [Mode(self.wn, self.zeta)]

    def step_response(self, t: FloatArray, release_time_s: float, step: float) -> FloatArray:
        """Exact x(t) for r = step·H(t - t_r) from rest at 0 (any damping), shape (N,)."""
        return step * _unit_step_second_order(np.asarray(t, dtype=np.float64) - release_time_s,
                                              self.wn, self.zeta)


def _unit_step_second_order(tau: FloatArray, wn: float, zeta: float) -> FloatArray:
    """Step response of wn²/(s² + 2ζwn s + wn²) at times tau (0 for tau < 0)."""
    tau_pos = np.maximum(tau, 0.0)
    lam = np.roots([1.0, 2.0 * zeta * wn, wn ** 2]).astype(complex)
    if abs(lam[0] - lam[1]) < 1e-9 * wn:  # critically damped: (1 - (1 + wn τ) e^{-wn τ})
        out = 1.0 - (1.0 + wn * tau_pos) * np.exp(-wn * tau_pos)
    else:  # 1 + Σ_i λ_j/(λ_i - λ_j) e^{λ_i τ}, from partial fractions of wn²/(s(s-λ1)(s-λ2))
        l1, l2 = lam
        out = (1.0 + (l2 / (l1 - l2)) * np.exp(l1 * tau_pos)
               + (l1 / (l2 - l1)) * np.exp(l2 * tau_pos)).real
    return np.where(tau >= 0.0, out, 0.0)


@dataclass(frozen=True)
class TwoCartChain:
    """`anchor –k1– m1 –k2– m2 –k3– wall`, dampers c1, c2 to ground (SI units).

    `structure` chooses how the input enters (see the module docstring); `held` is the
    direction e of the held displacement for `release` ((1, 0): cart 1 pulled by r,
    cart 2 held at its own rest — the lab's case 3).
    """

    m1: float
    m2: float
    k1: float
    k2: float
    k3: float
    c1: float
    c2: float
    structure: InputStructure = "release"
    held: tuple[float, float] = (1.0, 0.0)

    def __post_init__(self) -> None:
        _positive(m1=self.m1, m2=self.m2, k2=self.k2)
        _non_negative(k1=self.k1, k3=self.k3, c1=self.c1, c2=self.c2)
        if self.structure not in ("release", "anchor", "force"):
            raise IdentValueError("structure", "'release', 'anchor' or 'force'", self.structure)
        if self.k1 + self.k3 <= 0.0:
            raise IdentValueError("k1 + k3", "a chain tied to a wall (k1 + k3 > 0)", self.k1 + self.k3)

    @property
    def mass_matrix(self) -> FloatArray:
        return np.diag([self.m1, self.m2])

    @property
    def damping_matrix(self) -> FloatArray:
        return np.diag([self.c1, self.c2])

    @property
    def stiffness_matrix(self) -> FloatArray:
        return np.array([[self.k1 + self.k2, -self.k2], [-self.k2, self.k2 + self.k3]])

    @property
    def input_vector(self) -> FloatArray:
        """f in `M x'' + C x' + K x = f u` (N per unit of u), shape (2,)."""
        if self.structure == "release":
            return np.asarray(self.stiffness_matrix @ np.asarray(self.held, dtype=np.float64))
        if self.structure == "anchor":
            return np.array([self.k1, 0.0])
        return np.array([1.0, 0.0])

    def acceleration(self, x: FloatArray, v: FloatArray, u: float) -> FloatArray:
        """x'' = M⁻¹ (f u - C v - K x) for positions x (2,) and velocities v (2,) (m/s²)."""
        force = self.input_vector * u - self.damping_matrix @ v - self.stiffness_matrix @ x
        return np.asarray(force / np.array([self.m1, self.m2]))

    def state_space(self) -> StateSpace:
        m_inv = np.diag([1.0 / self.m1, 1.0 / self.m2])
        A = np.block([[np.zeros((2, 2)), np.eye(2)],
                      [-m_inv @ self.stiffness_matrix, -m_inv @ self.damping_matrix]])
        B = np.concatenate([np.zeros(2), m_inv @ self.input_vector])[:, None]
        C = np.hstack([np.eye(2), np.zeros((2, 2))])
        return StateSpace(A, B, C, np.zeros((2, 1)))

    def tf_coefficients(self) -> list[tuple[FloatArray, FloatArray]]:
        """[(num1, den), (num2, den)] from the adjugate formula, monic den, highest power first."""
        z11 = np.array([self.m1, self.c1, self.k1 + self.k2])
        z22 = np.array([self.m2, self.c2, self.k2 + self.k3])
        den = np.polysub(np.polymul(z11, z22), [self.k2 ** 2])
        f1, f2 = self.input_vector
        num1 = np.polyadd(f1 * z22, [self.k2 * f2])
        num2 = np.polyadd([self.k2 * f1], f2 * z11)
        lead = den[0]
        return [(_trim(num1 / lead), den / lead), (_trim(num2 / lead), den / lead)]

    def tf(self) -> list[control.TransferFunction]:
        return transfer_functions(self.tf_coefficients())

    def modes(self) -> list[Mode]:
        return modes_of(self.state_space().A)

    def dc_gains(self) -> FloatArray:
        """Static gains x/u: K⁻¹ f, shape (2,)."""
        return np.asarray(np.linalg.solve(self.stiffness_matrix, self.input_vector))


def _trim(poly: FloatArray, rtol: float = 1e-12) -> FloatArray:
    """Drop leading coefficients that are zero (exactly or to rounding)."""
    scale = float(np.max(np.abs(poly))) if poly.size else 0.0
    keep = np.flatnonzero(np.abs(poly) > rtol * scale)
    return poly[keep[0]:] if keep.size else np.zeros(1)


def describe(model: Any) -> str:
    """One line per mode, e.g. 'wn = 7.3230 rad/s, zeta = 0.05190'."""
    return "; ".join(f"wn = {m.wn:.4f} rad/s, zeta = {m.zeta:.5f}" for m in model.modes())
