"""Linear free response of one cart or the two-cart chain, batched over parameter sets.

After the release the carts move freely towards their rest positions `s` (m). In deviation
coordinates `z = (x - s, x')` (shape (n,), n = 2·carts):

    z' = A z,   A = [[0, I], [-Kt, -Ct]],

with the mass-normalised stiffness and damping matrices (the chain of `ident.physics`,
`anchor –k1– m1 –k2– m2 –k3– wall`, dampers c1, c2 to ground):

    one cart:   Kt = [wn²],                               Ct = [2 ζ wn]
    two carts:  Kt = [[a1 + b1, -b1], [-b2, b2 + a2]],    Ct = diag(g1, g2)
                a1 = k1/m1, b1 = k2/m1, b2 = k2/m2, a2 = k3/m2, g_i = c_i/m_i (1/s², 1/s).

Parameter vectors (`LINEAR_NAMES`) are rows of a (P, p) array so that a finite-difference
Jacobian is one batched call. This module holds no fitting and no I/O.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

LINEAR_NAMES: dict[int, tuple[str, ...]] = {
    1: ("wn_rad_s", "zeta"),
    2: ("k1_per_m1_s2", "k2_per_m1_s2", "k2_per_m2_s2", "k3_per_m2_s2", "c1_per_m1_s", "c2_per_m2_s"),
}


def stiffness_damping(lin: FloatArray, carts: int) -> tuple[FloatArray, FloatArray]:
    """Mass-normalised `Kt`, `Ct` of shape (P, carts, carts) from `lin` (P, 2 or 6)."""
    p = lin.shape[0]
    if carts == 1:
        wn, zeta = lin[:, 0], lin[:, 1]
        return (wn ** 2).reshape(p, 1, 1), (2.0 * zeta * wn).reshape(p, 1, 1)
    a1, b1, b2, a2, g1, g2 = (lin[:, i] for i in range(6))
    kt = np.empty((p, 2, 2))
    kt[:, 0, 0], kt[:, 0, 1], kt[:, 1, 0], kt[:, 1, 1] = a1 + b1, -b1, -b2, b2 + a2
    ct = np.zeros((p, 2, 2))
    ct[:, 0, 0], ct[:, 1, 1] = g1, g2
    return kt, ct


def state_matrix(lin: FloatArray, carts: int) -> FloatArray:
    """`A` (P, 2c, 2c) of the free response in deviation coordinates."""
    kt, ct = stiffness_damping(lin, carts)
    p = lin.shape[0]
    a = np.zeros((p, 2 * carts, 2 * carts))
    a[:, :carts, carts:] = np.eye(carts)
    a[:, carts:, :carts] = -kt
    a[:, carts:, carts:] = -ct
    return a


def linear_free_response(lin: FloatArray, z0: FloatArray, tau: FloatArray, carts: int) -> FloatArray:
    """Positions in deviation coordinates, shape (P, N, carts): `z(τ) = V e^{Λτ} V⁻¹ z0`.

    `z0` (P, 2c) is the state at τ = 0, `tau` (N,) s ≥ 0. Exact (eigendecomposition), so the
    linear baseline carries no integration error.
    """
    a = state_matrix(lin, carts)
    lam, vec = np.linalg.eig(a)                       # (P, n), (P, n, n)
    coef = np.linalg.solve(vec, z0[..., None].astype(complex))[..., 0]   # (P, n)
    expo = np.exp(lam[:, None, :] * tau[None, :, None])                 # (P, N, n)
    z = np.einsum("pin,pkn,pn->pki", vec[:, :carts, :], expo, coef)
    return np.asarray(z.real, dtype=np.float64)


def modes(lin: FloatArray, carts: int) -> list[tuple[float, float]]:
    """(wn rad/s, zeta) of each mode of the first parameter row, sorted by wn."""
    lam = np.linalg.eigvals(state_matrix(lin[:1], carts)[0])
    upper = lam[lam.imag > 0]
    if upper.size < carts:
        upper = lam
    out = sorted((float(abs(x)), float(-x.real / abs(x))) for x in upper if abs(x) > 0)
    return out[:carts]


def physical_from_modes(freqs: FloatArray, decays: FloatArray, shapes: FloatArray) -> FloatArray:
    """Two-cart `lin` (6,) from two modes: wn_j (rad/s), decay σ_j (1/s), shape r_j = x2/x1.

    Each mode's eigenvector (1, r_j) of `Kt` with eigenvalue wn_j² gives two linear equations
    per row: (a1 + b1) - b1 r_j = wn_j² and -b2 + (b2 + a2) r_j = wn_j² r_j. Damping:
    first-order modal perturbation 2σ_j = (u_j^T Ct φ_j)/(u_j^T φ_j) with u_j the left
    eigenvector, solved for (g1, g2) (equal when the split is unobservable). Values are
    clipped to be positive (a start value only).
    """
    lam2 = freqs ** 2
    r = shapes
    m1 = np.array([[1.0, -r[0]], [1.0, -r[1]]])
    d1, b1 = np.linalg.lstsq(m1, lam2, rcond=None)[0]
    m2 = np.array([[-1.0, r[0]], [-1.0, r[1]]])
    b2, d2 = np.linalg.lstsq(m2, lam2 * r, rcond=None)[0]
    a1, a2 = d1 - b1, d2 - b2
    kt = np.array([[d1, -b1], [-b2, d2]])
    w, left = np.linalg.eig(kt.T)
    rows = []
    for j in range(2):
        phi = np.array([1.0, r[j]])
        u = np.real(left[:, int(np.argmin(np.abs(w - lam2[j])))])
        denom = float(u @ phi) or 1.0
        rows.append([u[0] * phi[0] / denom, u[1] * phi[1] / denom])
    # In a symmetric chain both rows are (½, ½): only g1 + g2 is observable. A relative cutoff
    # keeps the minimum-norm split (equal damping) instead of amplifying round-off into it.
    g1, g2 = np.linalg.lstsq(np.array(rows), 2.0 * decays, rcond=1e-8)[0]
    floor = 1e-3 * float(lam2.min())
    lin = np.array([max(a1, floor), max(b1, floor), max(b2, floor), max(a2, floor),
                    max(g1, 1e-4), max(g2, 1e-4)])
    return lin
