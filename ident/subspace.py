"""Subspace start values: modes from a Hankel matrix of the response (pure numpy).

After a step the response is the free response of the augmented system (modes plus a
constant), so the sampled outputs obey y[k] = C_a Φ^k x_0 and the block-Hankel matrix

    H = [y[s + i q]]  (block row i = 0 … L, column s)

has rank n = 2m + 1 with column space the extended observability matrix Γ = [C; CΦ_q; …].
The SVD gives Γ (first n left singular vectors); shift invariance Γ_↓ = Γ_↑ Φ_q gives
Φ_q = Γ_↑⁺ Γ_↓ and the continuous poles s = ln(eig Φ_q) / (q Ts) (MOESP/N4SID on a free
response; Kung's method). Every sample is used: columns start at every index s while rows
step by q samples. The decimation q keeps the fastest mode at ~0.5 rad per row step, so
the poles do not crowd z = 1 however fast the sampling is.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: Radians per (decimated) row step for the fastest mode.
TARGET_ANGLE_RAD = 0.5


def decimation_for(omega_max: float, ts: float) -> int:
    """Row step q so that omega_max·q·Ts ≈ TARGET_ANGLE_RAD (q ≥ 1)."""
    return max(1, int(TARGET_ANGLE_RAD / max(omega_max * ts, 1e-12)))


def free_response_poles(y: FloatArray, ts: float, orders: tuple[int, ...], step: int = 1,
                        block_rows: int | None = None) -> list[NDArray[np.complex128]]:
    """Continuous poles (1/s) of a free response `y` (N, n_out), one array per state
    dimension in `orders` (one Hankel matrix and decomposition serves them all).

    `step` is the decimation q between block rows; `block_rows` L defaults to ~N/(3q) ≤ 40.
    """
    y2 = y.reshape(len(y), -1)
    n, n_out = y2.shape
    rows = block_rows or max(max(orders) + 1, min(40, n // (3 * step)))
    n_cols = n - rows * step
    if n_cols < max(orders) + 1:
        raise ValueError(f"expected more samples for a Hankel matrix, got {n}")
    hankel = np.vstack([y2[i * step:i * step + n_cols].T for i in range(rows + 1)])
    # left singular vectors of H = eigenvectors of H Hᵀ (small and square: a wide SVD is slow)
    _, vectors = np.linalg.eigh(hankel @ hankel.T)
    vectors = vectors[:, ::-1]
    out = []
    for order in orders:
        gamma = vectors[:, :order]
        phi = np.linalg.lstsq(gamma[:-n_out], gamma[n_out:], rcond=None)[0]
        z = np.linalg.eigvals(phi).astype(np.complex128)
        out.append(np.asarray(np.log(z) / (step * ts), dtype=np.complex128))
    return out


def oscillatory_modes(poles: NDArray[np.complex128], n_modes: int,
                      max_omega: float = np.inf) -> tuple[FloatArray, FloatArray] | None:
    """(σ, ω) of the `n_modes` least damped oscillatory poles (ζ < 0.5, ω < max_omega, which
    drops the noise poles an over-sized order picks up), ascending ω; None if too few."""
    upper = [p for p in poles if 1e-6 < p.imag < max_omega and -p.real < 0.5 * abs(p)]
    if len(upper) < n_modes:
        return None
    upper.sort(key=lambda p: -abs(p.real) / abs(p))  # least damped first
    chosen = sorted(upper[:n_modes], key=lambda p: p.imag)
    return (np.array([-p.real for p in chosen], dtype=np.float64),
            np.array([p.imag for p in chosen], dtype=np.float64))


def moesp(u: FloatArray, y: FloatArray, order: int,
          horizon: int | None = None) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Discrete (A, B, C, D) of `order` from input `u` (N,) and outputs `y` (N, n_out), PO-MOESP.

    Block Hankel matrices of past inputs/outputs W_p and future inputs U_f, outputs Y_f
    (`horizon` s block rows each). The LQ factorisation of [U_f; W_p; Y_f] removes the
    future inputs; the SVD of the part of Y_f explained by the past (L32) gives the extended
    observability matrix Γ_s (first `order` left singular vectors), hence C = Γ_s[0] and
    A = Γ_↑⁺ Γ_↓. B and D then solve a linear least-squares problem in the simulated output
    (x0 = 0, the data starting at rest). For inputs of any shape; for the lab's step after a
    long rest prefer `free_response_poles`.
    """
    u2 = np.asarray(u, dtype=np.float64).reshape(len(u), -1)
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    n, n_out = y2.shape
    n_in = u2.shape[1]
    s = horizon or max(order + 1, min(20, n // 10))
    cols = n - 2 * s + 1
    if cols < 2 * s * (n_in + n_out):
        raise ValueError(f"expected more samples for horizon {s}, got {n}")

    def block(x: FloatArray, start: int) -> FloatArray:
        return np.vstack([x[start + i:start + i + cols].T for i in range(s)])

    stacked = np.vstack([block(u2, s), block(u2, 0), block(y2, 0), block(y2, s)])
    r = np.asarray(np.linalg.qr(stacked.T, mode="r")).T  # L of the LQ factorisation
    a, b = s * n_in, s * n_in + s * (n_in + n_out)
    l32 = r[b:, a:b]
    left, _, _ = np.linalg.svd(l32, full_matrices=False)
    gamma = left[:, :order]
    c_mat = gamma[:n_out]
    a_mat = np.linalg.lstsq(gamma[:-n_out], gamma[n_out:], rcond=None)[0]
    b_mat, d_mat = _input_matrices(a_mat, c_mat, u2, y2)
    return a_mat, b_mat, c_mat, d_mat


def _input_matrices(a_mat: FloatArray, c_mat: FloatArray, u: FloatArray,
                    y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """B, D minimising ‖y - ŷ‖ with ŷ[k] = Σ_j C A^(k-1-j) B u[j] + D u[k] (linear in B, D),
    plus an output offset."""
    n, n_out = y.shape
    order = a_mat.shape[0]
    n_in = u.shape[1]
    columns = []
    for i in range(order):
        for m in range(n_in):
            state = np.zeros(order)
            response = np.zeros((n, n_out))
            e_i = np.zeros(order)
            e_i[i] = 1.0
            for k in range(n):
                response[k] = c_mat @ state
                state = a_mat @ state + e_i * u[k, m]
            columns.append(response.ravel())
    for m in range(n_in):
        for j in range(n_out):
            direct = np.zeros((n, n_out))
            direct[:, j] = u[:, m]
            columns.append(direct.ravel())
    for j in range(n_out):
        level = np.zeros((n, n_out))
        level[:, j] = 1.0
        columns.append(level.ravel())
    theta = np.linalg.lstsq(np.column_stack(columns), y.ravel(), rcond=None)[0]
    b_mat = theta[:order * n_in].reshape(order, n_in)
    d_mat = theta[order * n_in:order * n_in + n_in * n_out].reshape(n_in, n_out).T
    return np.asarray(b_mat, dtype=np.float64), np.asarray(d_mat, dtype=np.float64)
