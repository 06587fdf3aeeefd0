"""Fixed-step simulators: classical RK4 and explicit Euler, Euler with Coulomb friction.

Numpy (a jittered grid is marched by the compiled `kernel.march_affine`), no clocks. Error
orders (global): RK4 O(h⁴) (error ÷16 when h halves), Euler O(h) (÷2). For a linear system
x' = A x + B u with u constant over a step, one step of either method is itself linear,
x⁺ = Φ(h) x + Γ(h) u:

    RK4:   Φ = I + hA + (hA)²/2 + (hA)³/6 + (hA)⁴/24,   Γ = h (I + hA/2 + (hA)²/6 + (hA)³/24) B,
    Euler: Φ = I + hA,                                  Γ = h B,

which is what `linear_step_map` returns (the same numbers as stepping `rk4`/`euler`, without
the Python loop); both keep the true equilibrium -A⁻¹B u as their fixed point.

Single cart with dry (Coulomb) friction, accelerations in m/s² (f = μ g = Mf/m):

    x'' = -2ζ wn x' - wn² (x - r) - f sign(x'),

stepped by explicit Euler with a stick condition: a cart at rest stays at rest while the
spring pull |wn² (x - r)| ≤ f; when a moving cart's velocity would change sign within a step
(at τ = -v/a), it sticks (v = 0) if the spring pull at the step's end is ≤ f, and otherwise
slips back with the friction reversed for the remaining h - τ.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentValueError

FloatArray = NDArray[np.float64]
Method = Literal["rk4", "euler"]
Derivative = Callable[[float, FloatArray], FloatArray]


def _check_grid(t: FloatArray, substeps: int) -> None:
    if substeps < 1:
        raise IdentValueError("substeps", "an integer ≥ 1", substeps)
    if t.ndim != 1 or t.size < 1 or np.any(np.diff(t) <= 0):
        raise IdentValueError("t", "a 1-D strictly increasing time grid", f"shape {t.shape}")


def rk4(f: Derivative, x0: FloatArray, t: FloatArray, substeps: int = 1) -> FloatArray:
    """Classical Runge–Kutta 4 from x(t[0]) = x0; returns x at every t, shape (N, n)."""

    def step(tk: float, x: FloatArray, h: float) -> FloatArray:
        k1 = f(tk, x)
        k2 = f(tk + h / 2, x + h / 2 * k1)
        k3 = f(tk + h / 2, x + h / 2 * k2)
        k4 = f(tk + h, x + h * k3)
        return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    return _march(step, x0, t, substeps)


def euler(f: Derivative, x0: FloatArray, t: FloatArray, substeps: int = 1) -> FloatArray:
    """Explicit (forward) Euler from x(t[0]) = x0; returns x at every t, shape (N, n)."""

    def step(tk: float, x: FloatArray, h: float) -> FloatArray:
        return x + h * f(tk, x)

    return _march(step, x0, t, substeps)


def _march(step: Callable[[float, FloatArray, float], FloatArray], x0: FloatArray, t: FloatArray,
           substeps: int) -> FloatArray:
    """Apply `step(t_k, x, h)` `substeps` times per interval of the grid `t`; x at every t, (N, n)."""
    t = np.asarray(t, dtype=np.float64)
    _check_grid(t, substeps)
    x = np.asarray(x0, dtype=np.float64).copy()
    out = np.empty((t.size, x.size))
    out[0] = x
    for k in range(t.size - 1):
        h = (t[k + 1] - t[k]) / substeps
        for j in range(substeps):
            x = step(t[k] + j * h, x, h)
        out[k + 1] = x
    return out


def linear_step_map(A: FloatArray, B: FloatArray, h: float, method: Method) -> tuple[FloatArray, FloatArray]:
    """(Φ, Γ) of one fixed step of `method` for x' = A x + B u, u held over the step."""
    phi, gamma = linear_step_maps(A, B, np.array([h], dtype=np.float64), method)
    return phi[0], gamma[0]


def linear_step_maps(A: FloatArray, B: FloatArray, h: FloatArray, method: Method) -> tuple[FloatArray, FloatArray]:
    """(Φ (K, n, n), Γ (K, n, m)) of one step of `method` for each step length h (K,)."""
    n = A.shape[0]
    ha = np.asarray(h, dtype=np.float64)[:, None, None] * A
    eye = np.eye(n)
    hb = np.asarray(h, dtype=np.float64)[:, None, None] * B
    if method == "euler":
        return eye + ha, hb
    if method != "rk4":
        raise IdentValueError("method", "'rk4' or 'euler'", method)
    ha2 = ha @ ha
    ha3 = ha2 @ ha
    return eye + ha + ha2 / 2 + ha3 / 6 + ha3 @ ha / 24, (eye + ha / 2 + ha2 / 6 + ha3 / 24) @ hb


def linear_step_response(A: FloatArray, B: FloatArray, t: FloatArray, release_time_s: float,
                         step: float, method: Method, substeps: int = 1,
                         initial: FloatArray | None = None) -> FloatArray:
    """States (N, n) of x' = A x + B u for u = step·H(t - t_r), simulated with `method` on the
    grid from x(t_r) = `initial` (n,) (default: rest, 0): one partial step from t_r to the first
    sample after it, then the sample steps (each split in `substeps`). Samples before t_r hold
    `initial`. Uniform grids use Φ^k by eigen-decomposition."""
    t = np.asarray(t, dtype=np.float64)
    n = A.shape[0]
    x = np.zeros(n) if initial is None else np.asarray(initial, dtype=np.float64).reshape(n).copy()
    states = np.tile(x, (t.size, 1))
    first = int(np.searchsorted(t, release_time_s, side="left"))
    if first >= t.size:
        return states
    u_vec = B[:, 0] * step
    equilibrium = -np.linalg.solve(A, u_vec)
    h0 = t[first] - release_time_s
    phi0, gamma0 = linear_step_map(A, B, h0 / substeps, method)
    for _ in range(substeps):
        x = phi0 @ x + gamma0[:, 0] * step
    states[first] = x
    rest = t[first:]
    if rest.size == 1:
        return states
    steps = np.diff(rest)
    h = float(np.mean(steps))
    if np.max(np.abs(steps - h)) <= 1e-9 * h:
        phi, _ = linear_step_map(A, B, h / substeps, method)
        phi = np.linalg.matrix_power(phi, substeps)
        mu, vectors = np.linalg.eig(phi)
        coords = np.linalg.solve(vectors, (x - equilibrium).astype(complex))
        # a step the method cannot take stably (a fit's trial wn·h past its limit) grows without
        # bound to inf: the optimiser rejects that step, and `simple._check_start` a start there
        with np.errstate(over="ignore", invalid="ignore"):
            powers = mu[None, :] ** np.arange(rest.size)[:, None]
            states[first:] = equilibrium + ((powers * coords) @ vectors.T).real
        return states
    # a grid with jitter (a real export's clock): every step's own map, marched compiled
    from ident.physics.kernel import march_affine  # deferred: numba would slow `import ident`
    phis, gammas = linear_step_maps(A, B, steps / substeps, method)
    march_affine(phis, np.ascontiguousarray(gammas[:, :, 0] * step), x, substeps, states[first + 1:])
    return states


def euler_coulomb(wn: float, zeta: float, friction: float, r: float, t: FloatArray,
                  release_time_s: float, substeps: int = 1, velocity: float = 0.0) -> FloatArray:
    """Positions (N,) of x'' = -2ζwn x' - wn²(x - r) - f sign(x') from x = 0, released at t_r
    with velocity `velocity` (m/s; 0: from rest, a flick otherwise), explicit Euler with the
    stick condition of the module docstring."""
    t = np.asarray(t, dtype=np.float64)
    out = np.zeros(t.size)
    first = int(np.searchsorted(t, release_time_s, side="left"))
    x, v = 0.0, float(velocity)
    c, k, f = 2.0 * zeta * wn, wn * wn, abs(friction)
    previous = release_time_s
    for i in range(first, t.size):
        h = (t[i] - previous) / substeps
        for _ in range(substeps):
            spring = -k * (x - r)
            if v == 0.0:
                if abs(spring) <= f:
                    continue  # stuck: static friction holds the spring
                a = spring - f * np.sign(spring)
            else:
                a = spring - c * v - f * np.sign(v)
            x_new = x + h * v
            v_new = v + h * a
            if v != 0.0 and v_new * v < 0.0:
                # v reaches 0 at τ = -v/a within the step: stick there, or slip back with the
                # friction reversed for the rest of the step (no dwell step, so f → 0 gives Euler)
                pull = -k * (x_new - r)
                v_new = 0.0 if abs(pull) <= f else (pull - f * np.sign(pull)) * (h + v / a)
            x, v = x_new, v_new
        out[i] = x
        previous = t[i]
    return out
