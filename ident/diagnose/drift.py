"""The slow drift of a free cart's rest: the unmeasured wander of a hand-held cart.

When one cart is let go while the hand holds the other (the 2023 ECP `DOF1_en2_manual2` hand
steps: cart 1 moved by hand about 2 cm and held, cart 2 read), the held cart is no wall: the
hand lets it creep by a fraction of a millimetre to a few millimetres over the next seconds
(the 2025 records, which read both carts, show 100–400 counts). Through the coupling spring
that moves the free cart's equilibrium: with the held cart at u_h(τ),

    x'' = -wn² (x - rest - r(τ)) - 2 ζ wn x' - friction,    r(τ) = (k2 / k) (u_h(τ) - u_h(0)).

When the held cart is not read, r is unknown but slow: the hand wanders at well below the
ring's frequency. It is modelled as a cubic B-spline with knots `DRIFT_PERIODS` periods of the
lowest mode apart (a basis (N, K) on the work samples, every function 0 at τ = 0: the rest is
the one at the release), so it cannot take the ring's own loss per cycle (friction) or a
second mode (searched from 0.33× the main mode up). Parameters: the K spline coefficients
(`drift_knot_j_m`, metres of rest displacement) and the spacing (`drift_spacing_s`, fixed).
No I/O here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem

#: Knot spacing of the drift, in periods of the lowest mode: a cubic B-spline passes little
#: above 1/(spacing) Hz, a third of the main mode's frequency and below any searched mode.
DRIFT_PERIODS = 3.0
#: A window shorter than this many spacings cannot tell a drift from the rest's own offset
#: and the decay: not offered.
MIN_SPANS = 2.0


def drift_spacing(wn_rad_s: float) -> float:
    """The knot spacing (s) for a main mode of `wn_rad_s`."""
    return DRIFT_PERIODS * 2.0 * np.pi / wn_rad_s


def drift_basis(tau: FloatArray, spacing_s: float, end_s: float | None = None) -> FloatArray | None:
    """(N, K) cubic B-splines on uniform knots `spacing_s` apart from τ = 0 to past the end
    (`end_s`, by default the last τ), without the one function that is not 0 at τ = 0; None
    when the window is shorter than `MIN_SPANS` spacings."""
    import scipy.interpolate  # deferred: keeps `import ident` fast
    end = float(tau[-1]) if end_s is None else end_s
    if end < MIN_SPANS * spacing_s:
        return None
    spans = int(np.ceil(end / spacing_s - 1e-9))
    edge = spans * spacing_s
    knots = np.concatenate([np.zeros(3), np.linspace(0.0, edge, spans + 1), np.full(3, edge)])
    design = scipy.interpolate.BSpline.design_matrix(np.clip(tau, 0.0, edge), knots, 3).toarray()
    return np.asarray(design[:, 1:], dtype=np.float64)


#: The prior scale of the drift (m): a hand-held cart wanders by a few millimetres (DESIGN.md;
#: 100–400 counts on the ECP records, which the spring passes on in part), so the rest drifts by
#: about this much, and by about this much from one knot to the next.
DRIFT_PRIOR_M = 2e-3


def drift_penalty(spec: ModelSpec, free: NDArray[np.int_], sigma2: float) -> FloatArray | None:
    """(2K - 1, p) the root R of the penalty |R x|² = (σ²/s²) (Σ_j r_j² + Σ_j (r_{j+1} - r_j)²)
    on the rest drift's knots r among the free parameters x, s = `DRIFT_PRIOR_M` (None without
    a drift).

    The drift is an unmeasured wander of about s, from knot to knot too: with readings of noise
    variance σ², this penalty makes the fit the most probable drift under that prior. Where the
    readings see a knot, it is negligible; where they do not (a stuck cart does not feel its
    rest move within its dead band, ±F/wn²; a knot of a held-out block), the knot stays near its
    neighbours and near no drift instead of taking any value the fit happened to leave it at,
    e.g. one just inside the dead band, where a held-out refit's small step sets the cart moving."""
    if "rest_drift" not in spec.effects:
        return None
    names = spec.names
    at = np.array([k for k, i in enumerate(free) if names[i].startswith("drift_knot_")], dtype=int)
    if at.size == 0:
        return None
    root = np.zeros((2 * at.size - 1, free.size))
    rows = np.arange(at.size - 1)
    root[rows, at[:-1]], root[rows, at[1:]] = -1.0, 1.0
    root[at.size - 1 + np.arange(at.size), at] = 1.0
    out: FloatArray = np.sqrt(max(sigma2, 0.0)) / DRIFT_PRIOR_M * root
    return out


def slow_residual(prob: Problem, prediction: FloatArray) -> bool:
    """Whether the residual of `prediction` (N, 1) has enough slow content for a drift to be
    worth fitting: its least-squares projection on the drift's splines passes the selection's
    noise bound, n ln(SSE / (SSE - |projection|²)) > χ²_K(1 - 1e-3). A slow rest shift moves a
    free cart by about as much (x ≈ r below the ring), a stuck one less, so a drift that fails
    this cannot pass its own fit; the screen saves its fit on records with nothing slow left."""
    import scipy.stats  # deferred: keeps `import ident` fast
    if prob.drift is None:
        return False
    res = (prob.y - prediction)[:, 0]
    coef = np.linalg.lstsq(prob.drift, res, rcond=None)[0]
    slow = float(np.sum((prob.drift @ coef) ** 2))
    sse = float(np.sum(res ** 2))
    if sse <= 0.0 or slow <= 0.0:
        return False
    gain = res.size * float(np.log(sse / max(sse - slow, 1e-300 * sse)))
    return gain > float(scipy.stats.chi2.ppf(1 - 1e-3, prob.drift.shape[1]))


__all__ = ["DRIFT_PERIODS", "DRIFT_PRIOR_M", "MIN_SPANS", "drift_basis", "drift_penalty", "drift_spacing",
           "slow_residual"]
