"""The compiled inner loop of the cart simulator (numba): one parameter set at a time.

Why compiled: the diagnosis simulates each candidate model hundreds of times (finite-
difference Jacobians, forward selection, blocked cross-validation), with dry friction that
needs per-step branching (stick, reversal). In numpy every sub-step costs ~20 array calls
on 4-element states; here one cart costs ~10 ns linear and ~25 ns with dry friction
(`tools/bench_kernel.py`).

State of one parameter set, c carts (n = 2c): deviation from rest e = x - s and velocity v
(`z = (e, v)`, shape (n,)), and the pre-sliding friction state w (c,). One sub-step of
length h (see `ident.physics.free` for the derivation):

    a(z, w, t) = G u(t) - d v|v| - κ e³ - cubic springs(e) - w·[σ > 0]   (c,) m/s²
    z_mid = Φ_{h/2} z + Γ_{h/2} a(z, w, t)
    z⁺    = Φ_h z + Γ_h a(z_mid, w_mid, t + h/2)                      (exact linear part)
    w⁺    = F sgn v + (w - F sgn v) e^{-σ|v|h/F}   (v at mid-step; Dahl, exact for v fixed)

then Coulomb friction with stick on the carts without pre-sliding (`_coulomb`). No I/O.

Compiled with numpy's error model (no division here can be by zero: each divisor is checked or
is a difference of opposite signs, so the Python model's check of every division is spared), the
small helpers inlined, and `simulate_rows` without reference counting (see there).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@numba.njit(error_model="numpy", cache=True, inline="always")
def _input_value(u: FloatArray, switch: FloatArray, k: int, q: int, frac: float, lo: float, hi: float) -> float:
    """Input column q at fraction `frac` of the step from sample k - 1 to k: linear between
    the samples where `switch[k - 1, q]` is NaN; else held, u[k - 1] until the switch
    fraction φ = `switch[k - 1, q]` and u[k] from there (a force a controller applies,
    switched between samples): over the sub-step [lo, hi] (fractions of the step) its mean,
    which keeps the sub-step's impulse (linear interpolation had smeared an edge over the
    whole step)."""
    phi = switch[k - 1, q]
    if np.isnan(phi):
        return float(u[k - 1, q] + (u[k, q] - u[k - 1, q]) * frac)
    before = min(max((phi - lo) / (hi - lo), 0.0), 1.0)
    return float(u[k - 1, q] * before + u[k, q] * (1.0 - before))


@numba.njit(error_model="numpy", cache=True, inline="always")
def _accel(z: FloatArray, w: FloatArray, inp: FloatArray, c: int, kt: FloatArray, drag: FloatArray,
           cubic: float, kappa: FloatArray, sigma: FloatArray, out: FloatArray) -> None:
    """Extra accelerations (beyond the linear chain) at state z into `out` (c,)."""
    for i in range(c):
        v = z[c + i]
        out[i] = inp[i] - drag[i] * v * abs(v) - kappa[i] * z[i] ** 3
        if sigma[i] > 0.0:
            out[i] -= w[i]
    if cubic != 0.0:
        if c == 1:
            out[0] -= kt[0, 0] * cubic * z[0] ** 3
        else:
            # per spring: k1 on e1, k2 on e2 - e1, k3 on e2 (mass-normalised rows of Kt)
            b1, b2 = -kt[0, 1], -kt[1, 0]
            a1, a2 = kt[0, 0] - b1, kt[1, 1] - b2
            e12 = z[1] - z[0]
            out[0] -= cubic * (a1 * z[0] ** 3 - b1 * e12 ** 3)
            out[1] -= cubic * (a2 * z[1] ** 3 + b2 * e12 ** 3)


@numba.njit(error_model="numpy", cache=True, inline="always")
def _dahl(w: FloatArray, z: FloatArray, c: int, f: FloatArray, sigma: FloatArray, h: float,
          out: FloatArray) -> None:
    """Dahl state after h with the velocity held: w → F sgn v exponentially (rate σ|v|/F)."""
    for i in range(c):
        v = z[c + i]
        if sigma[i] <= 0.0 or f[i] <= 0.0 or v == 0.0:
            out[i] = w[i]
            continue
        target = f[i] if v > 0.0 else -f[i]
        out[i] = target + (w[i] - target) * np.exp(-sigma[i] * abs(v) * h / f[i])


@numba.njit(error_model="numpy", cache=True, inline="always")
def _matvec_add(m: FloatArray, x: FloatArray, out: FloatArray, add: bool) -> None:
    for i in range(m.shape[0]):
        s = 0.0
        for j in range(m.shape[1]):
            s += m[i, j] * x[j]
        out[i] = out[i] + s if add else s


@numba.njit(error_model="numpy", cache=True, inline="always")
def _coulomb(z: FloatArray, wz: FloatArray, gam: FloatArray, kt: FloatArray, c: int, fk: FloatArray,
             fs: FloatArray, sigma: FloatArray, inp: FloatArray, h: float, af: FloatArray,
             sgn: FloatArray, held: FloatArray, x_rev: FloatArray, theta: FloatArray,
             rev: FloatArray) -> None:
    """Dry friction on the end state `wz` (n,) of a step from `z`, in place.

    Friction opposes the velocity at the step's start (from rest: the motion about to
    begin); a cart at rest stays stuck when the static level fs can hold it (Moreau). When
    the velocity reverses inside the step (at θh, θ = v/(v - v⁺)) the cart sticks there if
    |spring + input| ≤ fs, else friction flips: +2 f sgn over the rest r = (1-θ)h adds
    (f sgn r², 2 f sgn r) to (e, v), so the error per reversal is O(f h²).
    """
    any_f = False
    for i in range(c):
        af[i] = 0.0
        held[i] = 0.0
        sgn[i] = 0.0
        if fk[i] <= 0.0 or sigma[i] > 0.0:
            continue
        any_f = True
        v_old = z[c + i]
        s = np.sign(v_old) if v_old != 0.0 else np.sign(wz[c + i])
        sgn[i] = s
        g = gam[c + i, i]
        if v_old == 0.0 and abs(wz[c + i]) <= g * fs[i]:
            held[i] = 1.0
            af[i] = -wz[c + i] / g if g > 0.0 else 0.0
        else:
            af[i] = -fk[i] * s
    if not any_f:
        return
    _matvec_add(gam, af, wz, True)
    for i in range(c):
        if held[i] != 0.0:
            # exactly at rest: g·(-v/g) leaves ~1e-20 m/s, and a cart that is not exactly at
            # rest is slipping (kinetic friction), so a held cart would creep away
            wz[c + i] = 0.0
    for i in range(c):
        x_rev[i] = z[i]
        theta[i] = 0.0
        rev[i] = 0.0
        v_old = z[c + i]
        if fk[i] <= 0.0 or sigma[i] > 0.0 or held[i] != 0.0 or v_old == 0.0:
            continue
        if np.sign(wz[c + i]) == -sgn[i]:
            rev[i] = 1.0
            theta[i] = min(max(v_old / (v_old - wz[c + i]), 0.0), 1.0)
            x_rev[i] = z[i] + 0.5 * v_old * theta[i] * h
    for i in range(c):
        if rev[i] == 0.0:
            continue
        pull = inp[i]
        for j in range(c):
            pull -= kt[i, j] * x_rev[j]
        rem = (1.0 - theta[i]) * h
        if abs(pull) <= fs[i]:
            wz[i] = x_rev[i]
            wz[c + i] = 0.0
        else:
            wz[i] += fk[i] * sgn[i] * rem * rem
            wz[c + i] += 2.0 * fk[i] * sgn[i] * rem


#: Rows of `simulate_rows`' scratch array (SCRATCH_ROWS, 2c): the state and the step's work.
SCRATCH_ROWS = 13


@numba.njit(error_model="numpy", cache=True, inline="always")
def _row_terms(c: int, m_in: int, gin: FloatArray, drag: FloatArray, cubic: float, kappa: FloatArray,
               sigma: FloatArray, fk: FloatArray) -> tuple[bool, bool, bool, bool]:
    """Which terms a parameter row has: (an input, pre-sliding, a smooth force, Coulomb friction)."""
    has_input = False
    for i in range(c):
        for q in range(m_in):
            if gin[i, q] != 0.0:
                has_input = True
    presliding, nonlinear, coulomb = False, cubic != 0.0, False
    for i in range(c):
        if sigma[i] > 0.0:
            presliding = True
        if drag[i] != 0.0 or kappa[i] != 0.0:
            nonlinear = True
        if fk[i] > 0.0 and sigma[i] <= 0.0:
            coulomb = True
    return has_input, presliding, has_input or nonlinear or presliding, coulomb


# Without numba's reference counting (`_nrt=False`): every array the loop binds, an inlined
# helper's arguments included, took an atomic increment and decrement per sub-step (~150 ns of a
# dry-friction step's ~200); so nothing is allocated here: `scratch` holds the work arrays.
# (`_nrt` is numba's own target option, `numba.core.options.TargetOptions`, absent from its stubs.)
@numba.njit(error_model="numpy", cache=True, _nrt=False)  # type: ignore[call-overload]
def simulate_rows(phi: FloatArray, gam: FloatArray, phih: FloatArray, gamh: FloatArray, phi_fine: FloatArray,
                  gam_fine: FloatArray, phih_fine: FloatArray, gamh_fine: FloatArray, kt: FloatArray,
                  z0: FloatArray, fk: FloatArray, fs: FloatArray, sigma: FloatArray, drag: FloatArray,
                  cubic: FloatArray, kappa: FloatArray, gin: FloatArray, u: FloatArray, switch: FloatArray,
                  dt: float, substeps: int, fine: int, out: FloatArray, end: FloatArray, scratch: FloatArray) -> None:
    """Deviations e (P, N, c) into `out`, and the last sample's state (P, 2c) into `end`,
    for every parameter row.

    phi/phih (P, n, n), gam/gamh (P, n, c): zero-order-hold maps over h and h/2, and the
    `*_fine` ones over h/`fine` and h/(2 `fine`); kt (P, c, c) mass-normalised stiffness; z0
    (P, n); fk, fs, sigma, drag, kappa (P, c); cubic (P,); gin (P, c, m) input gains; u (N, m)
    inputs at the samples, linear between them where `switch` (N, m) is NaN, else held
    (`_input_value`); dt the sample step (s), split into `substeps`, and a step in which a held
    input switches (0 < switch < 1) into `fine` times as many; `scratch` (SCRATCH_ROWS, n) work
    space.
    """
    n_rows, n_samples, c = out.shape
    n = 2 * c
    m_in = u.shape[1]
    z, mid, wz = scratch[0], scratch[1], scratch[2]
    w, w_mid, acc, inp = scratch[3, :c], scratch[4, :c], scratch[5, :c], scratch[6, :c]
    af, sgn, held, x_rev, theta, rev = (scratch[7, :c], scratch[8, :c], scratch[9, :c], scratch[10, :c],
                                        scratch[11, :c], scratch[12, :c])
    for p in range(n_rows):
        # this row's maps and coefficients
        phi_p, gam_p, phih_p, gamh_p, kt_p = phi[p], gam[p], phih[p], gamh[p], kt[p]
        fk_p, fs_p, sigma_p, drag_p, kappa_p = fk[p], fs[p], sigma[p], drag[p], kappa[p]
        gin_p, cubic_p = gin[p], cubic[p]
        for r in range(SCRATCH_ROWS):
            for i in range(n):
                scratch[r, i] = 0.0
        for i in range(n):
            z[i] = z0[p, i]
        has_input, presliding, smooth, coulomb = _row_terms(c, m_in, gin_p, drag_p, cubic_p, kappa_p, sigma_p, fk_p)
        can_stop = coulomb and not has_input and not presliding
        for i in range(c):
            out[p, 0, i] = z[i]
        k = 1
        while k < n_samples:
            count = substeps * fine if _switches(u, switch, k, m_in) else substeps
            phi_s, gam_s, phih_s, gamh_s = ((phi_fine[p], gam_fine[p], phih_fine[p], gamh_fine[p]) if count > substeps
                                            else (phi_p, gam_p, phih_p, gamh_p))
            h = dt / count
            step = 1.0 / count
            for j in range(count):
                frac0 = j * step
                # input at the sub-step start and middle (linear between samples, or held)
                for i in range(c):
                    inp[i] = 0.0
                    for q in range(m_in):
                        inp[i] += gin_p[i, q] * _input_value(u, switch, k, q, frac0, frac0, frac0 + step)
                _matvec_add(phi_s, z, wz, False)
                if smooth:
                    _accel(z, w, inp, c, kt_p, drag_p, cubic_p, kappa_p, sigma_p, acc)
                    _matvec_add(phih_s, z, mid, False)
                    _matvec_add(gamh_s, acc, mid, True)
                    _dahl(w, z, c, fk_p, sigma_p, 0.5 * h, w_mid)
                    for i in range(c):
                        inp[i] = 0.0
                        for q in range(m_in):
                            inp[i] += gin_p[i, q] * _input_value(u, switch, k, q, frac0 + 0.5 * step,
                                                                 frac0, frac0 + step)
                    _accel(mid, w_mid, inp, c, kt_p, drag_p, cubic_p, kappa_p, sigma_p, acc)
                    _matvec_add(gam_s, acc, wz, True)
                if coulomb:
                    _coulomb(z, wz, gam_s, kt_p, c, fk_p, fs_p, sigma_p, inp, h, af, sgn, held, x_rev, theta, rev)
                if smooth:
                    _dahl(w, mid, c, fk_p, sigma_p, h, w_mid)
                    for i in range(c):
                        w[i] = w_mid[i]
                for i in range(n):
                    z[i] = wz[i]
            for i in range(c):
                out[p, k, i] = z[i]
            k += 1
            if can_stop and _all_held(z, kt_p, fs_p, c):
                for kk in range(k, n_samples):
                    for i in range(c):
                        out[p, kk, i] = z[i]
                break
        for i in range(n):
            end[p, i] = z[i]


@numba.njit(error_model="numpy", cache=True, inline="always")
def _switches(u: FloatArray, switch: FloatArray, k: int, m_in: int) -> bool:
    """Whether a held input switches inside the step from sample k - 1 to k."""
    for q in range(m_in):
        phi = switch[k - 1, q]
        if 0.0 < phi < 1.0 and u[k - 1, q] != u[k, q]:
            return True
    return False


@numba.njit(error_model="numpy", cache=True, inline="always")
def _all_held(z: FloatArray, kt: FloatArray, fs: FloatArray, c: int) -> bool:
    """Every cart at rest and held by static friction: nothing moves again."""
    for i in range(c):
        if z[c + i] != 0.0:
            return False
        pull = 0.0
        for j in range(c):
            pull -= kt[i, j] * z[j]
        if abs(pull) > fs[i]:
            return False
    return True


@numba.njit(error_model="numpy", cache=True)
def march_affine(phi: FloatArray, gam: FloatArray, x0: FloatArray, substeps: int, out: FloatArray) -> None:
    """States after each step k of x ← Φ_k x + γ_k, applied `substeps` times per step, from
    x0 (n,), into `out` (K, n); Φ (K, n, n), γ (K, n): a linear system's steps of varying
    length (a jittered clock), each with its own map."""
    n = x0.size
    x = x0.copy()
    nxt = np.empty(n)
    for k in range(phi.shape[0]):
        for _ in range(substeps):
            for i in range(n):
                acc = gam[k, i]
                for j in range(n):
                    acc += phi[k, i, j] * x[j]
                nxt[i] = acc
            for i in range(n):
                x[i] = nxt[i]
        for i in range(n):
            out[k, i] = x[i]
