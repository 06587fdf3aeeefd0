"""What two carts read through cart 1's encoder alone can tell: the identifiable friction.

With x2 = α z (α > 0) the chain (notation of `ident.physics.chain`, friction F_i in m/s²)

    x1'' = -(a1 + b1) x1 + b1 x2 - g1 x1' - F1 sgn x1'
    x2'' =  b2 x1 - (b2 + a2) x2 - g2 x2' - F2 sgn x2'

becomes the same chain in z with b1 -> α b1, b2 -> b2/α, a1 + b1 and b2 + a2 kept, F2 -> F2/α,
z(0) = x2(0)/α: cart 1's motion, sticking included, does not change (cart 2 sticks when
|b2 x1 - (b2 + a2) x2| ≤ r2 F2, which scales by 1/α on both sides: each cart's breakaway
ratio r_i = Fs_i / F_i is kept, so r2 is identifiable wherever cart 2 sticks). So cart 1's encoder
fixes F1, g1, g2, a1 + b1, b2 + a2 and b1 b2, but not b1, b2 or F2 apart: cart 2's friction
(m/s²) is not identifiable. What is: F2 / b2 = f2 / k2 (m), cart 2's friction force over the
coupling spring's stiffness, the stretch of that spring that cart 2's friction balances (how
far cart 1 must move to change the spring's pull on a stuck cart 2 by its friction): cart 2's
friction in cart 1's coordinate, unchanged by α.

Its standard deviation is the delta method's on the covariance with the flat direction
(d/dα of the parameters at α = 1) projected out: for a function of the parameters that α
leaves unchanged, the gradient is orthogonal to that direction and the projection is exact,
while the plain Gauss-Newton inverse divides by a singular value that is finite-difference
noise. No I/O here.
"""

from __future__ import annotations

import numpy as np

from ident.diagnose.fitting import FitResult
from ident.diagnose.problem import FloatArray, Problem

#: The report's name of cart 2's friction through cart 1's encoder (f2 / k2, metres).
CART2_FRICTION = "coulomb_cart2_per_coupling_m"
#: The unidentifiable parameter it replaces.
CART2_ACCEL = "coulomb_accel_m_s2_cart2"
#: Effects under which the scale symmetry is exact (cart 2's coordinate enters them scaled,
#: or not at all). Drag and cubic springs share one coefficient between the carts: a scaled
#: cart 2 would need its own, so with them the symmetry is only approximate.
SYMMETRIC = ("coulomb_friction", "static_friction", "presliding", "coupled_mode", "quantization")


def one_encoder(prob: Problem) -> bool:
    """Two carts read through cart 1's encoder only."""
    return prob.carts == 2 and prob.y.shape[1] == 1


def flat_direction(result: FitResult) -> FloatArray:
    """(p,) d θ / d α at α = 1 (module docstring): the direction along which cart 1's
    reading does not change; zero on the fixed parameters and when the symmetry is not exact."""
    spec, theta = result.spec, result.theta
    d = np.zeros_like(theta)
    if any(e not in SYMMETRIC for e in spec.effects) or spec.n_inputs:
        return d
    names = spec.names
    at = {n: i for i, n in enumerate(names)}
    b1, b2 = theta[at["k2_per_m1_s2"]], theta[at["k2_per_m2_s2"]]
    d[at["k1_per_m1_s2"]], d[at["k2_per_m1_s2"]] = -b1, b1
    d[at["k2_per_m2_s2"]], d[at["k3_per_m2_s2"]] = -b2, b2
    d[at["x0_2_m"]], d[at["v0_2_m_s"]] = -(theta[at["x0_2_m"]] - theta[at["rest_2_m"]]), -theta[at["v0_2_m_s"]]
    if CART2_ACCEL in at:
        d[at[CART2_ACCEL]] = -theta[at[CART2_ACCEL]]
    for i, n in enumerate(names):
        if n in spec.fixed:
            d[i] = 0.0
    return d


def covariance(prob: Problem, result: FitResult, scale: FloatArray) -> FloatArray:
    """(p, p) Gauss-Newton covariance σ² (JᵀJ)⁻¹ of the free parameters on the subspace
    orthogonal to the flat direction (zero rows and columns for fixed parameters).
    `scale` (p,) typical magnitudes: finite-difference steps and column scaling."""
    spec, theta = result.spec, result.theta
    free = np.array([i for i, n in enumerate(spec.names) if n not in spec.fixed], dtype=int)
    s = np.maximum(np.abs(scale[free]), 1e-12)
    h = 1e-6 * np.maximum(np.abs(theta[free]), s)
    rows = np.repeat(theta[None, :], free.size + 1, axis=0)
    rows[1 + np.arange(free.size), free] += h
    with np.errstate(all="ignore"):
        pred = spec.predict(rows, prob.dt, prob.y.shape[0])[:, prob.train, :].reshape(rows.shape[0], -1)
    jac = np.nan_to_num(((pred[1:] - pred[0]) / h[:, None]).T) * s[None, :]     # (m, p_free), scaled
    m = jac.shape[0]
    sigma2 = result.sse_train / max(m - free.size, 1)
    d = flat_direction(result)[free] / s
    basis = np.eye(free.size)
    if np.linalg.norm(d) > 0:
        # an orthonormal basis of the complement of d: the gauge fixed by projecting it out
        basis = np.linalg.svd(np.eye(free.size) - np.outer(d, d) / float(d @ d))[0][:, :free.size - 1]
    reduced = basis.T @ (jac.T @ jac) @ basis
    cov_free = sigma2 * basis @ np.linalg.pinv(reduced) @ basis.T
    cov = np.zeros((theta.size, theta.size))
    cov[np.ix_(free, free)] = cov_free * np.outer(s, s)
    return cov


def identifiable_friction(prob: Problem, result: FitResult, scale: FloatArray,
                          values: dict[str, float], std: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """The Coulomb block's (values, 1-sigma) with cart 2's friction (m/s², unidentifiable)
    replaced by `CART2_FRICTION` = F2 / b2 (m) and its delta-method standard deviation;
    cart 1's friction keeps its value, its std from the projected covariance."""
    if CART2_ACCEL not in values:
        return values, std
    names = result.spec.names
    at = {n: i for i, n in enumerate(names)}
    cov = covariance(prob, result, scale)
    i_f1, i_f2, i_b2 = at["coulomb_accel_m_s2"], at[CART2_ACCEL], at["k2_per_m2_s2"]
    f2, b2 = abs(float(result.theta[i_f2])), float(result.theta[i_b2])
    grad = np.zeros(result.theta.size)
    grad[i_f2], grad[i_b2] = np.sign(result.theta[i_f2]) / b2, -f2 / b2 ** 2
    out = {k: v for k, v in values.items() if k != CART2_ACCEL}
    out[CART2_FRICTION] = f2 / b2
    out_std = {k: v for k, v in std.items() if k != CART2_ACCEL}
    out_std["coulomb_accel_m_s2"] = float(np.sqrt(max(cov[i_f1, i_f1], 0.0)))
    out_std[CART2_FRICTION] = float(np.sqrt(max(float(grad @ cov @ grad), 0.0)))
    return out, out_std


Values = dict[str, float]


def identifiable_model(params: Values, std: Values, friction: tuple[Values, Values] | None) -> tuple[Values, Values]:
    """A one-encoder model's (parameters, 1-sigma) as reported: cart 2's friction in m/s² (set
    by the fit's arbitrary scale of cart 2's coordinate, `flat_direction`) replaced by the
    friction effect's identifiable `CART2_FRICTION` and its std (`friction`: that effect's
    values and stds from `identifiable_friction`)."""
    if CART2_ACCEL not in params or friction is None:
        return params, std
    values, stds = friction
    out = {k: v for k, v in params.items() if k != CART2_ACCEL}
    out_std = {k: v for k, v in std.items() if k != CART2_ACCEL}
    out[CART2_FRICTION] = values[CART2_FRICTION]
    if CART2_FRICTION in stds:
        out_std[CART2_FRICTION] = stds[CART2_FRICTION]
    return out, out_std


def typical_scale(prob: Problem, result: FitResult) -> FloatArray:
    """(p,) typical magnitudes of a two-cart fit's parameters: the linear block's and the
    state's from `starts.linear_typical`, a friction of 1 % of the largest stiffness times the
    swing, and |θ| (at least 1e-6) for the rest."""
    from ident.diagnose.starts import linear_typical
    theta = result.theta
    out = np.maximum(np.abs(theta), 1e-6)
    head = linear_typical(theta, prob.carts, prob.amplitude)
    out[:head.size] = head
    if "coulomb_friction" in result.spec.effects:
        out[result.spec.block("coulomb_friction")] = 0.01 * float(np.max(theta[:4])) * prob.amplitude
    return out


__all__ = ["CART2_ACCEL", "CART2_FRICTION", "covariance", "flat_direction", "identifiable_friction",
           "identifiable_model", "one_encoder", "typical_scale"]
