"""The linear baseline of a diagnosis: its model spec, and its fit from a modal start
(`starts`) or, with a force input, from the ringing's frequencies. No I/O here."""

from __future__ import annotations

import numpy as np

from ident.diagnose import starts
from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem
from ident.modal import fit_modes
from ident.physics.measures import spectral_peaks

#: One cart: the strongest spectral peaks tried as its mode (`linear_starts`).
START_PEAKS = 3


def base_spec(prob: Problem, fixed: dict[str, float]) -> ModelSpec:
    if prob.y.shape[1] < prob.carts:   # cart 2 unseen: its rest only shifts its start, fix it
        fixed = {**fixed, "rest_2_m": 0.0}
    if prob.drift is not None:
        fixed = {**fixed, "drift_spacing_s": prob.drift_spacing_s}
    return ModelSpec((), prob.carts, fixed, prob.inputs, prob.held, prob.y.shape[1], prob.drift, prob.input_switch,
                     prob.still_until)


def fit_baseline(prob: Problem, fixed: dict[str, float]) -> FitResult:
    spec = base_spec(prob, fixed)
    n_in = spec.n_inputs * prob.carts
    best: FitResult | None = None
    for theta0 in linear_starts(prob):
        lower, upper = starts.linear_bounds(theta0, prob.carts)
        typical = starts.linear_typical(theta0, prob.carts, prob.amplitude)
        if n_in:
            gain = _input_gain_start(prob, theta0)
            theta0 = np.concatenate([theta0, gain])
            lower = np.concatenate([lower, np.full(n_in, -np.inf)])
            upper = np.concatenate([upper, np.full(n_in, np.inf)])
            typical = np.concatenate([typical, np.maximum(np.abs(gain), 1e-6)])
        result = fit(spec, theta0, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=50,
                     cross_validate=True, anchor=prob.anchor)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


def linear_starts(prob: Problem) -> list[FloatArray]:
    """Linear | x0 | v0 | rest start vectors: from a modal fit of the free response, or, with
    a force input, from the ringing's frequencies (spectral peaks of the sample differences,
    where the input's slow shape no longer dominates) with the carts at rest at the start."""
    if prob.inputs is None and prob.carts == 1:
        # the strongest of the position's peaks may be no ring: a free cart dragged in
        # stick-slip steps by a wandering held cart, or a drift, leaves its slow steps the
        # largest peak; each of the strongest peaks is fitted as the mode and the modal fit that
        # leaves the least residual starts the baseline
        fits = [fit_modes(prob.tau, prob.y, np.array([w])) for w in one_cart_peaks(prob.y, prob.dt)]
        return starts.linear_starts(min(fits, key=lambda f: f.sse), prob.carts)
    if prob.inputs is None:
        peaks = spectral_peaks(prob.y, prob.dt, prob.carts)
        out = starts.linear_starts(fit_modes(prob.tau, prob.y, peaks), prob.carts)
        # the velocity's spectrum too when it peaks elsewhere: the position's favours slow
        # motion, and a ring that friction stops within a few periods has a broad, low peak
        # beside the slow drift a held cart's wander leaves after it (the fit keeps the better)
        fast = spectral_peaks(np.diff(prob.y, axis=0), prob.dt, prob.carts)
        if np.any(np.abs(fast / peaks - 1.0) > 0.2):
            out += starts.linear_starts(fit_modes(prob.tau, prob.y, fast), prob.carts)
        return out
    wn = spectral_peaks(np.diff(prob.y, axis=0), prob.dt, prob.carts, min_rad_s=1.0)
    c = prob.carts
    at_rest = np.zeros(c)   # a cart not read (two carts through one encoder) starts at its rest, 0
    at_rest[:prob.y.shape[1]] = prob.y[0]
    state = np.concatenate([at_rest, np.zeros(c), at_rest])
    if c == 1:
        return [np.concatenate([[wn[0], 0.05], state])]
    coupling = max(0.5 * (wn[1] ** 2 - wn[0] ** 2), 0.05 * wn[0] ** 2)
    lin = np.array([wn[0] ** 2, coupling, coupling, wn[0] ** 2, 0.1 * wn[0], 0.1 * wn[0]])
    return [np.concatenate([lin, state])]


def one_cart_peaks(y: FloatArray, dt: float) -> list[float]:
    """The one cart's candidate modes (rad/s): the `START_PEAKS` strongest peaks of the
    positions' spectrum and of the velocities', those 15 % from every other. A ring that dry
    friction stops in its first eighth has no position peak among a long window's strongest
    (the Hann window weighs its start ~0.01; the slow stick-slip steps a wandering held cart
    drags it through after that take all three: red team `coulomb+held_cart` 9903, a 5.9 Hz
    ring stopped in 2 s of a 16 s window, fitted at 0.18 Hz, fit 0.6 %); the velocity's
    spectrum weighs a ring's ω² times more than those steps."""
    out: list[float] = []
    for w in [*spectral_peaks(y, dt, START_PEAKS), *spectral_peaks(np.diff(y, axis=0), dt, START_PEAKS)]:
        if all(abs(w - q) > 0.15 * q for q in out):
            out.append(float(w))
    return out


def _input_gain_start(prob: Problem, theta0: FloatArray) -> FloatArray:
    """Input gains (m/s² per unit, input-major) from the quasi-static response K x ≈ G u:
    the least-squares slope of each output against each input, times the stiffness."""
    assert prob.inputs is not None
    u = prob.inputs.reshape(prob.inputs.shape[0], -1)
    wn2 = theta0[0] ** 2 if prob.carts == 1 else float(np.max(theta0[:4]))
    du = u - u[0]
    dy = prob.y - prob.y[0]
    slope = np.linalg.lstsq(du, dy, rcond=None)[0]             # (m, outputs)
    gains = np.zeros((u.shape[1], prob.carts))
    gains[:, :slope.shape[1]] = wn2 * slope
    return gains.ravel()


__all__ = ["base_spec", "fit_baseline"]
