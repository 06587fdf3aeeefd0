"""The final model refitted on a finer grid than the selection's work grid: its parameters.

The selection fits every model on at most `window.MAX_WORK_SAMPLES` work samples (one in D of
the window's): it compares many models, and that keeps each fit cheap. The chosen model's
parameters need not be read off that grid. Kept only one sample in D, the readings carry a
D-th of their information (their noise is not averaged away: every D-th sample is taken),
and the simulation steps D sample periods at a time, so a cart's stick and breakaway land on
the coarse step. Two carts with Coulomb friction read through cart 1's encoder alone (own
generator, `tools/bench_diagnose.py --one-encoder 20 --seed 45`): cart 2's identifiable
friction was 6.0 % off on a grid of one sample in 7 (reported σ 5 %); refitted on every
sample, 1.1 % (σ 2.9 %); within 5 % in 16 -> 18 of the 20 runs.

So the final model is fitted on from its work-grid optimum (a few Gauss-Newton steps within
the bounds its last effect was fitted within) on every sample of the window, or on one in d
when the window holds more than `FINE_SAMPLES`, over the same span, and its parameters and
their σ are reported from that fit. A refit that does not lower the cost keeps the work
grid's parameters, with its σ on the finer grid (`fitting.fit`). An encoder lattice and the
breakaway ratios keep their work-grid values (`KEPT`). The whole-window fit %, the figures and
every judgement of the selection stay on the work grid. Pure; no I/O.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ident.diagnose.candidates import Trial
from ident.diagnose.drift import drift_basis
from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.held_fit import work_grid
from ident.diagnose.problem import FloatArray, Problem
from ident.diagnose.window import Window
from ident.physics.free import switched_input

#: The finer grid holds at most this many samples (a 10 s record at 200 Hz is fitted whole).
FINE_SAMPLES = 2500
#: Function evaluations of the refit on the finer grid (it starts at the work grid's optimum).
FINE_NFEV = 25
#: Effects whose parameters keep their work-grid values and σ (`refit_fine`).
KEPT = ("quantization", "static_friction")


def fine_decimation(decimation: int, n_samples: int) -> int:
    """One sample in how many the finer grid keeps of a window of `n_samples` samples
    (`FINE_SAMPLES` at most); the work grid's `decimation` when it is no finer."""
    return min(decimation, max(1, math.ceil(n_samples / FINE_SAMPLES)))


def refit_fine(prob: Problem, final: FitResult, bounds: Trial, win: Window, t: FloatArray, y: FloatArray,
               held: FloatArray | None, u: FloatArray | None) -> tuple[Problem, FitResult]:
    """(the problem on the finer grid, the final model fitted on it) or (`prob`, `final`) when
    the work grid keeps every sample already. `bounds`: the trial whose bounds and typical
    magnitudes cover the final model's parameters (its last effect's, `backward.Elimination`).
    `t` (N,) s and `y` (N, observed) m the record the work grid samples from `win.start` on
    every `win.decimation`-th sample, `held` the held cart's estimated motion from `win.start` on
    (`held_fit.held_motion`, every sample) or None, `u` (N, m) the force input or None."""
    last = win.start + (prob.tau.size - 1) * win.decimation     # the work grid's last sample
    d = fine_decimation(win.decimation, last - win.start + 1)
    if d >= win.decimation:
        return prob, final
    idx = np.arange(win.start, last + 1, d)
    tau = t[idx] - t[win.start]
    fine_held = None
    if prob.held is not None and held is not None:
        fine_held = work_grid(held, d)[:idx.size]    # the work grid's estimate, every d-th sample
    inputs = switch = None
    if prob.inputs is not None and u is not None:
        values, switches = switched_input(u[win.start:], d)
        inputs, switch = values[:idx.size], switches[:idx.size]
    drift = None
    if prob.drift is not None:
        drift = drift_basis(tau, prob.drift_spacing_s, end_s=float(prob.tau[-1]))
        if drift is None or drift.shape[1] != prob.drift.shape[1]:
            return prob, final
    fine = dataclasses.replace(prob, tau=tau, y=y[idx], dt=prob.dt * d / win.decimation,
                               train=np.ones(idx.size, dtype=bool), held=fine_held, inputs=inputs, drift=drift,
                               input_switch=switch, anchor=0)
    # kept as found: an encoder lattice is the sensor's, judged on the work grid by its
    # readings' likelihood (refitted, its blur went to its bound on resampled real readings); a
    # breakaway ratio is chosen on a grid, as no finite difference moves a stick decision
    sensor = tuple(n for e in KEPT if e in final.spec.effects for n in final.spec.names_of(e))
    fixed = {**final.spec.fixed, **{n: float(final.theta[final.spec.names.index(n)]) for n in sensor}}
    spec = dataclasses.replace(final.spec, fixed=fixed, held=fine_held, inputs=inputs, input_switch=switch, drift=drift)
    result = fit(spec, final.theta, bounds.lower, bounds.upper, bounds.typical, fine.dt, fine.y, fine.train,
                 max_nfev=FINE_NFEV)
    std = result.std.copy()
    for n in sensor:
        i = final.spec.names.index(n)
        std[i] = final.std[i]
    return fine, dataclasses.replace(result, spec=dataclasses.replace(result.spec, fixed=final.spec.fixed), std=std)


__all__ = ["FINE_NFEV", "FINE_SAMPLES", "KEPT", "fine_decimation", "refit_fine"]
