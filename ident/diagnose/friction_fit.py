"""The dry-friction candidate's fit: two stages (large-amplitude part, then every sample)
from several starts, since where a frictional cart stops depends discontinuously on the
parameters. No I/O here."""

from __future__ import annotations

import numpy as np

from ident.diagnose.evidence import EvidenceResult
from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem, best_rows


def fit_friction(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                 typical: FloatArray, ev: EvidenceResult, max_nfev: int) -> FitResult:
    """Friction fits in two stages, from two starts.

    The linear fit has put the extra loss into viscous damping, and where a frictional cart
    stops depends discontinuously on the parameters; so each start is first fitted on the
    large-amplitude part of the run (until the half-cycle peaks fall below 30 % of the
    first), where the cost is smooth, then on every sample. Starts: the current damping and
    the damping implied by the envelope ratio (one cart).
    """
    n_cut = _large_amplitude_samples(prob, ev)
    candidates = [theta0]
    if prob.carts == 1:
        # the linear fit put the friction's loss into ζ: restart from a lighter damping, the
        # envelope's (a free ringing) or a quarter of the current one, friction on a grid
        zeta_alt = 0.25 * theta0[1]
        if ev.envelope_ratio < 1.0:
            half_period = np.pi / theta0[0]
            zeta_alt = -np.log(max(ev.envelope_ratio, 1e-3)) / half_period / theta0[0]
        alt = theta0.copy()
        alt[1] = float(np.clip(zeta_alt, 1e-4, 0.9 * max(theta0[1], 1e-4)))
        at = spec.block("coulomb_friction").start
        f_max = theta0[0] ** 2 * prob.amplitude
        candidates.append(best_rows(spec, prob, alt, slice(at, at + 1),
                                     [np.array([g * f_max]) for g in (0.003, 0.01, 0.03, 0.1)]))
    else:
        candidates += _two_cart_friction_starts(spec, prob, theta0)
    short = spec.cut(n_cut)
    best: FitResult | None = None
    for start in candidates:
        first = fit(short, start, lower, upper, typical, prob.dt, prob.y[:n_cut], prob.train[:n_cut],
                    max_nfev=2 * max_nfev)
        result = fit(spec, first.theta, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


def _two_cart_friction_starts(spec: ModelSpec, prob: Problem, theta0: FloatArray) -> list[FloatArray]:
    """Two carts: the linear fit put both frictions' loss into c1/m1 and c2/m2, and which cart
    rubs shows only in how each mode's envelope decays. Restart from a quarter of that damping
    with the friction on cart 1 only, cart 2 only or both, on a grid of levels (the best row).

    Through one encoder the linear chain is not identifiable: x1 sees only the characteristic
    polynomial, a + d, ad - bc and the dampings (a = (k1+k2)/m1, b = k2/m1, c = k2/m2,
    d = (k2+k3)/m2), so the linear fit may land on the mirrored chain (a and d exchanged)
    where friction on the wrong cart fits best. Also start from that mirror, b c kept, with
    its dampings exchanged and not reduced (on 6 one-encoder runs, a quarter of them left 2 of
    the mirrors short of the noise floor, 0.9 and 1.0 points)."""
    at = spec.block("coulomb_friction").start
    chains = [theta0.copy()]
    if spec.observed < spec.carts:
        a, d, bc = theta0[0] + theta0[1], theta0[2] + theta0[3], theta0[1] * theta0[2]
        for share in (0.5, 0.7):
            b = share * d
            c = bc / max(b, 1e-12)
            if c < a:
                mirror = theta0.copy()
                mirror[:6] = [d - b, b, c, a - c, theta0[5], theta0[4]]
                chains.append(mirror)
    f_max = float(np.max(theta0[:4])) * prob.amplitude
    patterns = (np.array([1.0, 0.0]), np.array([0.0, 1.0]), np.array([1.0, 1.0]))
    chains[0][4:6] = 0.25 * theta0[4:6]
    out = []
    for chain in chains:
        out.append(best_rows(spec, prob, chain, slice(at, at + 2),
                              [g * f_max * p for p in patterns for g in (0.003, 0.01, 0.03, 0.1)]))
    return out


def _large_amplitude_samples(prob: Problem, ev: EvidenceResult) -> int:
    """Work samples up to a quarter period after the last peak above 30 % of the first."""
    amps = ev.extrema[:, 1]
    n = prob.tau.size
    if amps.size < 4:
        return n
    last = float(ev.extrema[np.flatnonzero(amps >= 0.3 * amps[0])[-1], 0])
    quarter = 0.25 * (ev.extrema[-1, 0] - ev.extrema[0, 0]) / max(amps.size - 1, 1) * 2
    return int(min(n, max(np.searchsorted(prob.tau, last + quarter), 40)))


__all__ = ["fit_friction"]
