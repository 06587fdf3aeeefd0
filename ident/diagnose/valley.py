"""The two-cart chains one encoder cannot tell apart, and moves across them. Pure.

Read through cart 1's encoder alone, a chain (a1, b1, b2, a2) = (k1/m1, k2/m1, k2/m2, k3/m2) is
seen by its two modes only: every chain with the same modes' wn² (the trace A + D and
A D - b1 b2, A = a1 + b1, D = b2 + a2) fits the linear motion as well, a one-parameter family
(the "valley", its share s = (A - w1) / (w2 - w1) between the modes' wn² w1 < w2). Dry
friction breaks the tie (where a cart sticks depends on its own stiffness), so `friction_fit`
starts its fits across the family (`valley_chains`), with its modes moved (`other_modes`,
`with_modes`), and walks a fit along it (`valley_walk_rows`).
"""

from __future__ import annotations

import numpy as np

from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray

#: Where a one-encoder chain's friction fit starts A = (k1+k2)/m1 between the squares of the
#: modes' frequencies (0: the lower, 1: the upper), D = (k2+k3)/m2 = trace - A.
VALLEY = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
#: A one-encoder chain's friction fit also starts with one of its modes kept and the other's wn²
#: this many times the kept one's (the best row of each, across the valley and friction levels).
SECOND_MODES = (0.125, 0.25, 0.5, 2.0, 4.0, 8.0)
#: The valley walk's shares along the one-encoder family (`friction_fit._walk_valley`), as
#: logit(share) = ln(share / (1 - share)): ±0.35, ±1.05, ..., ±3.85 (shares 0.021-0.979, each
#: end approached in equal ratios; 0.5 itself, where A = D leaves the dampings' split undefined,
#: is left out).
WALK_LOGITS = tuple(sign * (0.35 + 0.7 * k) for sign in (-1.0, 1.0) for k in range(6))
#: And these steps in logit(share) about the fit's own share.
WALK_STEPS = (-0.3, -0.1, 0.1, 0.3)


def mode_squares(chain: FloatArray) -> tuple[float, float]:
    """The undamped modes' wn² (lower, upper) of a chain (a1, b1, b2, a2, ...): the eigenvalues
    of [[a1 + b1, -b1], [-b2, b2 + a2]]."""
    a1, b1, b2, a2 = chain[:4]
    big_a, big_d = a1 + b1, b2 + a2
    trace, det = big_a + big_d, big_a * big_d - b1 * b2
    disc = np.sqrt(max(trace * trace - 4.0 * det, 0.0))
    return float(0.5 * (trace - disc)), float(0.5 * (trace + disc))


def valley_chains(chain: FloatArray, spec: ModelSpec, shares: tuple[float, ...] = VALLEY
                   ) -> list[tuple[FloatArray, FloatArray]]:
    """`chain` moved across the one-encoder family (see `friction_fit._two_cart_friction_starts`) to each
    `VALLEY` share: the modes' wn² kept (trace and A D - b1 b2), the dampings moved to keep
    g1 + g2 and g1 D + g2 A, the gauge b1 inside the range where every spring is positive
    (`identifiable`); each with cart 2's start as fitted, and at rest."""
    a1, b1, b2, a2, g1, g2 = chain[:6]
    big_a, big_d = a1 + b1, b2 + a2
    trace, det = big_a + big_d, big_a * big_d - b1 * b2
    w1, w2 = mode_squares(chain)
    g_sum, g_mix = g1 + g2, g1 * big_d + g2 * big_a
    names = spec.names
    x2, v2, r2 = names.index("x0_2_m"), names.index("v0_2_m_s"), names.index("rest_2_m")
    out = []
    for share in shares:
        new_a = w1 + share * (w2 - w1)
        new_d = trace - new_a
        bc = new_a * new_d - det
        if bc <= 0.0 or abs(new_d - new_a) < 1e-9 * trace:
            continue
        nb1 = float(np.sqrt(bc / new_d * new_a))     # inside (bc / D, A): both walls' springs > 0
        nb2 = bc / nb1
        ng1 = float(np.clip((g_mix - g_sum * new_a) / (new_d - new_a), 0.0, g_sum))
        row = chain.copy()
        row[:6] = [new_a - nb1, nb1, nb2, new_d - nb2, ng1, g_sum - ng1]
        still = row.copy()
        still[x2], still[v2] = still[r2], 0.0
        out.append((row, still))
    return out


def with_modes(chain: FloatArray, kept: float, other: float) -> FloatArray:
    """`chain` with its modes' wn² `kept` and `other` (any chain with them: the valley then moves
    it across)."""
    new_a = 0.5 * (kept + other)
    new_d = kept + other - new_a
    b = float(np.sqrt(max(new_a * new_d - kept * other, 0.0)))
    row = chain.copy()
    row[:4] = [new_a - b, b, b, new_d - b]
    return row


def other_modes(chain: FloatArray) -> list[tuple[float, float]]:
    """(kept, other) modes' wn² of the starts `SECOND_MODES` makes of `chain`: each of its two
    modes kept (the lower only when they are within 20 %), the other moved; none within 20 % of
    the chain's own pair.

    Through one encoder the linear fit's modes need not be the chain's: a cart that friction
    stops within a few cycles hardly shows its own mode, and the linear fit imitates friction's
    straight decay by two close modes (generated seed 61607245: 8.05 and 8.76 rad/s for a true
    8.45 and 17.4, cart 2 then pinned by a stiff wall spring, 0.38 points under the noise
    floor), or the one seen is the upper (red team two_cart_coulomb_y1 1038: a light cart 1 at
    44.6 rad/s on a heavy cart 2 at 13.5; 8.5 points under the floor)."""
    low, high = mode_squares(chain)
    kept = (low,) if high < 1.44 * low else (low, high)
    own = np.array([low, high])
    return [(k, k * r) for k in kept for r in SECOND_MODES
            if not np.all(np.abs(np.sort([k, k * r]) / own - 1.0) < 0.44)]


def valley_walk_rows(spec: ModelSpec, theta: FloatArray, logits: tuple[float, ...] = WALK_LOGITS
                     ) -> list[FloatArray]:
    """The starts of `friction_fit._walk_valley`: the one-encoder chain `theta` (a1, b1, b2, a2, g1, g2, ...)
    moved across the family to every share of `logits` and the `WALK_STEPS` about its own share
    s = (A - w1) / (w2 - w1) (A = a1 + b1, w1 < w2 the modes' wn²), cart 1's friction kept and
    cart 2's scaled with b2 (F2 / b2 kept). Empty when the carts are not coupled (b2 <= 0)."""
    low, high = mode_squares(theta)
    if not theta[2] > 0.0 or not high > low:
        return []
    own = float(np.clip((theta[0] + theta[1] - low) / (high - low), 1e-4, 1.0 - 1e-4))
    at = np.log(own / (1.0 - own))
    shares = tuple(float(1.0 / (1.0 + np.exp(-z))) for z in (*logits, *(at + d for d in WALK_STEPS)))
    friction = spec.block("coulomb_friction").start
    rows = []
    for moved, _ in valley_chains(theta, spec, shares):
        moved[friction + 1] = theta[friction + 1] * moved[2] / theta[2]
        rows.append(moved)
    return rows


__all__ = ["SECOND_MODES", "VALLEY", "WALK_LOGITS", "WALK_STEPS", "mode_squares", "other_modes", "valley_chains",
           "valley_walk_rows", "with_modes"]
