"""The lab's carts after a release: free response with every nonlinear force, batched.

The motion in deviation coordinates `z = (x - s, x')` (n = 2·carts, s the rest positions) is

    z' = A z + B (a_nl(z, w, t) + a_f),   B = [0; I],   A from `ident.physics.chain`,

with the extra accelerations a_nl (m/s², per cart i)

    cubic springs     each spring k (e + γ e³): one cart -wn² γ e³; two carts per spring
                      (k1 on e1, k2 on e2 - e1, k3 on e2), γ (1/m²) > 0 hardening, < 0 softening;
                      or per cart about its rest, -κ_i e_i³ (κ in 1/(m² s²))
    quadratic drag    -d_i v_i |v_i|                      (d = drag/m, 1/m)
    inputs            Σ_q G_iq u_q(t)                     (a force per mass, or the other
                      cart's measured motion through the coupling spring: G = k2/m, 1/s²)
    pre-sliding       -w_i, Dahl: w' = σ_i (v - |v| w / F_i), |w| → F_i (σ in 1/s²)

and a_f dry (Coulomb) friction of kinetic level F_i and static level Fs_i ≥ F_i (m/s²) with
a stick condition, on the carts without pre-sliding (Dahl replaces the stick: at small
amplitude it acts as an extra spring σ, at large amplitude it saturates to ±F).

Scheme (one sub-step h, `ident.physics.kernel`): the linear part exactly (zero-order hold,
`Φ = e^{Ah}`, `Γ = ∫₀ʰ e^{Aτ} dτ B`); the smooth forces held at their value at the
predicted mid-step state (second order); Dahl's state exactly for the mid-step velocity;
dry friction per step (stick by Moreau's rule, a velocity reversal inside a step located
and either stuck or slipped with the friction flipped for the rest of the step, error
O(F h²) per reversal). A zero nonlinear coefficient reproduces the linear model to
rounding. Shapes: parameter sets P, samples N, carts c. No fitting and no I/O here.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.physics.chain import state_matrix

FloatArray = NDArray[np.float64]

#: Largest sub-step (s), largest h·wn the nonlinear scheme is allowed, and largest h·√σ
#: for pre-sliding (its small-amplitude spring σ is explicit: the mid-step rule is stable
#: to h√σ < 2, and its O((h√σ)²) error only touches the sub-millimetre pre-sliding motion).
MAX_SUBSTEP_S = 1.2e-2
MAX_H_WN = 0.3
#: h·wn with a cubic spring: its force is taken at the mid-step (O(h²)), and a spring that
#: softens by 30 % over the swing, stepped at h·wn 0.23 (a 36 rad/s cart at 79 Hz), leaves a
#: 30 µm ring the diagnosis named a coupled mode (red team cubic_softening seed 3001); at 0.15 none
MAX_H_WN_CUBIC = 0.15
MAX_H_SQRT_SIGMA = 0.8
#: A step in which a held input switches (`switched_input`: a motor's duty changed between
#: two work samples) is split into this many times its sub-steps. Within a sub-step the
#: input is held at its mean there, which keeps the impulse but not when it came: a force
#: switched on at 2/3 of a 20 ms step moved a 3.2 Hz cart 352 µm by the step's end instead of
#: 235, and the diagnosis credited a cubic spring or pre-sliding (whose finer sub-steps put
#: the switch nearer its place) with the fit that the linear model had lost (5 of 30 generated
#: motor pulses without any effect; none at 8 sub-steps). The error falls as the square of
#: the sub-step.
SWITCH_SUBSTEPS = 8


@dataclass(frozen=True)
class NonlinearTerms:
    """Per-set coefficients, each (P, carts) or None when absent (see the module docstring).

    `friction_m_s2` F_i ≥ 0 (kinetic); `static_friction_m_s2` Fs_i ≥ F_i (default F_i);
    `presliding_per_s2` σ_i (Dahl stiffness; > 0 turns the cart's friction into Dahl's);
    `cubic_per_m2` γ (P,) relative cubic stiffness of every spring; `cubic_per_m2_s2` κ_i a
    cubic restoring term per cart about its rest; `drag_per_m` d_i;
    `input_gain` G (P, carts, m) with the inputs `u` (N, m) given to `simulate_free`.
    """

    friction_m_s2: FloatArray | None = None
    static_friction_m_s2: FloatArray | None = None
    presliding_per_s2: FloatArray | None = None
    cubic_per_m2: FloatArray | None = None
    cubic_per_m2_s2: FloatArray | None = None
    drag_per_m: FloatArray | None = None
    input_gain: FloatArray | None = None


def _zoh(a: FloatArray, h: float, carts: int) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """`Φ = e^{Ah}` (P, n, n) and `Γ = ∫₀ʰ e^{Aτ}dτ B` (P, n, c) from one augmented expm, on
    h and on h/2: (Φ_h, Γ_h, Φ_{h/2}, Γ_{h/2})."""
    p, n, _ = a.shape
    aug = np.zeros((p, n + carts, n + carts))
    aug[:, :n, :n] = a * h
    aug[:, carts:n, n:] = np.eye(carts) * h
    half, whole = _expm_halves(aug)
    return whole[:, :n, :n], whole[:, :n, n:], half[:, :n, :n], half[:, :n, n:]


def _squarings(norm: float) -> int:
    """Scaling 2^s of `expm_batch`: ‖M/2^s‖₁ ≤ 0.25."""
    return max(0, int(np.ceil(np.log2(max(norm, 1e-300) / 0.25))))


def _expm_halves(m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(e^{M/2}, e^M), each exactly what `expm_batch` gives: where M/2 scales to the same matrix
    (s - 1 squarings of the M's s), the series is summed once and e^M is one squaring more."""
    norm = float(np.max(np.abs(m).sum(axis=-2)))
    s = _squarings(norm)
    if s == 0 or _squarings(0.5 * norm) != s - 1:
        return expm_batch(0.5 * m), expm_batch(m)
    half = _series_squared(m / (2.0 ** s), s - 1)
    return half, half @ half


def expm_batch(m: FloatArray, order: int = 12) -> FloatArray:
    """e^M for a batch (P, n, n): Taylor series after scaling by 2^s, then s squarings.

    With ‖M/2^s‖₁ ≤ 0.25 the truncation error of 12 terms is below 1e-17 relative
    (scipy's batched Padé is ~100× slower on these tiny matrices).
    """
    s = _squarings(float(np.max(np.abs(m).sum(axis=-2))))
    return _series_squared(m / (2.0 ** s), s, order)


def _series_squared(a: FloatArray, s: int, order: int = 12) -> FloatArray:
    """The Taylor series of e^a (P, n, n) to `order`, squared s times."""
    eye = np.broadcast_to(np.eye(a.shape[-1]), a.shape)
    term = eye.copy()
    total = eye.copy()
    for k in range(1, order + 1):
        term = term @ a / k
        total = total + term
    for _ in range(s):
        total = total @ total
    return total


def substeps(dt: float, wn_max: float, h_wn: float = MAX_H_WN) -> int:
    """Sub-steps per sample so that |h| ≤ MAX_SUBSTEP_S and |h|·wn_max ≤ `h_wn` (`dt` < 0: a
    run backward in time)."""
    h_max = min(MAX_SUBSTEP_S, h_wn / max(wn_max, 1e-9))
    return max(1, int(np.ceil(abs(dt) / h_max - 1e-9)))


def _owned(a: FloatArray, shape: tuple[int, ...]) -> FloatArray:
    """A writable C-contiguous float64 copy broadcast to `shape`: the kernel is compiled for
    one array type only (a read-only or strided view would compile another, ~10 s)."""
    return np.array(np.broadcast_to(np.asarray(a, dtype=np.float64), shape), dtype=np.float64, order="C")


def _per_cart(value: FloatArray | None, p: int, carts: int, default: float = 0.0) -> FloatArray:
    if value is None:
        return np.full((p, carts), default)
    return _owned(value, (p, carts))


@dataclass(frozen=True)
class StepMaps:
    """One grid step's compiled data for P parameter sets (what the kernel needs)."""

    phi: FloatArray
    gam: FloatArray
    phih: FloatArray
    gamh: FloatArray
    #: the same maps on the sub-steps of a step in which a held input switches (`fine` times
    #: finer: `SWITCH_SUBSTEPS`, or 1 and the maps above where no input switches)
    phi_fine: FloatArray
    gam_fine: FloatArray
    phih_fine: FloatArray
    gamh_fine: FloatArray
    kt: FloatArray
    fk: FloatArray
    fs: FloatArray
    sigma: FloatArray
    drag: FloatArray
    cubic: FloatArray
    kappa: FloatArray
    gin: FloatArray
    dt: float
    substeps: int
    fine: int
    carts: int


def step_maps(lin: FloatArray, dt: float, carts: int, terms: NonlinearTerms, n_inputs: int = 0,
              switching: bool = False) -> StepMaps:
    """The zero-order-hold maps and force coefficients of `lin` (P, 2 or 6) on a grid `dt`;
    with `switching` (a held input switches inside a step) also those of its finer sub-steps."""
    p = lin.shape[0]
    a = state_matrix(lin, carts)
    fk = np.abs(_per_cart(terms.friction_m_s2, p, carts))
    sigma = np.maximum(_per_cart(terms.presliding_per_s2, p, carts), 0.0)
    gin = (np.zeros((p, carts, n_inputs)) if terms.input_gain is None
           else _owned(terms.input_gain, (p, carts, n_inputs)))
    wn_max = float(np.max(np.abs(np.linalg.eigvals(a))))
    cubic = any(c is not None and np.any(np.asarray(c) != 0.0) for c in (terms.cubic_per_m2, terms.cubic_per_m2_s2))
    m = substeps(dt, wn_max, MAX_H_WN_CUBIC if cubic else MAX_H_WN)
    if sigma.size and np.max(sigma) > 0:
        m = max(m, int(np.ceil(dt * np.sqrt(np.max(sigma)) / MAX_H_SQRT_SIGMA - 1e-9)))
    phi, gam, phih, gamh = (_owned(g, g.shape) for g in _zoh(a, dt / m, carts))
    fine = SWITCH_SUBSTEPS if switching and n_inputs else 1
    phi_f, gam_f, phih_f, gamh_f = ((_owned(g, g.shape) for g in _zoh(a, dt / (m * fine), carts))
                                    if fine > 1 else (phi, gam, phih, gamh))
    return StepMaps(phi, gam, phih, gamh, phi_f, gam_f, phih_f, gamh_f,
                    _owned(-a[:, carts:, :carts], (p, carts, carts)), fk,
                    np.maximum(_per_cart(terms.static_friction_m_s2, p, carts, 0.0), fk), sigma,
                    _per_cart(terms.drag_per_m, p, carts),
                    np.zeros(p) if terms.cubic_per_m2 is None else _owned(terms.cubic_per_m2, (p,)),
                    _per_cart(terms.cubic_per_m2_s2, p, carts), gin, float(dt), m, fine, carts)


def run_maps(maps: StepMaps, z0: FloatArray, n_samples: int, u: FloatArray | None = None,
             switch: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Deviations (P, N, carts) on the grid from the state `z0` (P, 2c), and the state
    (deviations, velocities) at the last sample (P, 2c). `u` (N, m) inputs at the samples,
    linear between them, or held where `switch` (N, m) is finite (`switched_input`)."""
    # the compiled kernel imports numba (~0.5-1.5 s): loaded when a simulation first runs
    from ident.physics.kernel import SCRATCH_ROWS, simulate_rows
    p, c = maps.fk.shape
    if u is None:
        u_arr, switches = _NO_INPUT, _NO_INPUT
    else:
        m = np.size(u) // n_samples
        u_arr = _read_only_arg(np.reshape(u, (n_samples, m)), (n_samples, m))
        switches = _linear(n_samples, m) if switch is None else _read_only_arg(switch, (n_samples, m))
    out = np.empty((p, n_samples, c))
    end = np.empty((p, 2 * c))
    # numba's compiled code raises no floating-point warnings: no errstate needed around it
    simulate_rows(maps.phi, maps.gam, maps.phih, maps.gamh, maps.phi_fine, maps.gam_fine, maps.phih_fine,
                  maps.gamh_fine, maps.kt, _read_only_arg(z0, (p, 2 * c)), maps.fk, maps.fs, maps.sigma, maps.drag,
                  maps.cubic, maps.kappa, maps.gin, u_arr, switches, maps.dt, maps.substeps, maps.fine, out, end,
                  np.empty((SCRATCH_ROWS, 2 * c)))
    return out, end


#: No input (the kernel reads no column of it): one shared (1, 0) array for `u` and `switch`.
_NO_INPUT: FloatArray = np.zeros((1, 0))


@functools.lru_cache(maxsize=8)
def _linear(n_samples: int, m: int) -> FloatArray:
    """The `switch` of inputs linear between samples (all NaN), shared: the kernel only reads it."""
    return np.full((n_samples, m), np.nan)


def _read_only_arg(a: FloatArray, shape: tuple[int, ...]) -> FloatArray:
    """`a` itself when it already is what the kernel is compiled for (writable, C-contiguous
    float64 of `shape`; the kernel only reads it), else an owned copy (`_owned`): the rig steps
    one sample at a time, where the copies cost more than the step."""
    if (isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == shape and a.flags.c_contiguous
            and a.flags.writeable):
        return a
    return _owned(a, shape)


def simulate_free(lin: FloatArray, z0: FloatArray, dt: float, n_samples: int, carts: int,
                  terms: NonlinearTerms, u: FloatArray | None = None,
                  switch: FloatArray | None = None) -> FloatArray:
    """Deviations from rest x - s at τ_k = k·dt, shape (P, N, carts).

    `lin` (P, 2 or 6) linear parameters (see `chain`), `z0` (P, 2c) deviation and velocity
    at τ = 0, `u` (N, m) inputs on the same grid (with `terms.input_gain`), linear between
    samples, or held where `switch` (N, m) is finite (`switched_input`). A `dt` < 0 runs the
    carts backward in time from τ = 0 (the same equations: a reversal flips the friction as it
    does forward; a cart that stuck before τ = 0 is not found stuck).
    """
    n_inputs = 0 if u is None else int(np.size(u) // n_samples)
    switching = switch is not None and bool(np.any((switch > 0.0) & (switch < 1.0)))
    return run_maps(step_maps(lin, dt, carts, terms, n_inputs, switching), z0, n_samples, u, switch)[0]


def switched_input(u: FloatArray, decimation: int) -> tuple[FloatArray, FloatArray]:
    """An input (N, m) held from each sample to the next (a controller's log of what it
    applies) on every `decimation`-th sample, as `simulate_free` holds it: (values (n, m) at
    those samples, switch (n, m)), where over the step from work sample k to k + 1 the input
    is values[k] until the fraction switch[k] of the step and values[k + 1] after it, the
    fraction that keeps the step's impulse (exact for one switch within the step; 1 where
    nothing changes). n = ceil(N / decimation); the last step ends with the record."""
    n, d = -(-u.shape[0] // decimation), decimation
    part = u[:n * d]
    if part.shape[0] < n * d:
        part = np.concatenate([part, np.repeat(part[-1:], n * d - part.shape[0], axis=0)])
    steps = part.reshape(n, d, -1)
    values = np.array(steps[:, 0, :], dtype=np.float64)
    mean = steps.mean(axis=1)
    after = np.concatenate([values[1:], values[-1:]])
    jump = after - values
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = np.where(jump != 0.0, (after - mean) / jump, 1.0)
    return values, np.clip(phi, 0.0, 1.0)
