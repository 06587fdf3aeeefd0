"""What the held cart's reading error leaves in the parameters: a σ for errors in variables.

The held cart's motion is an input of the model, taken as known (`held_fit.held_motion`
estimates it from its reading); the Gauss-Newton σ of a fit counts only the free cart's
misfit. Where the reading hardly shows the part of the held cart's motion that is not its pull
by the free cart (a hand's wander of a fraction of a millimetre read through a lattice of a
millimetre or more), the estimate's error is as large as that part, the coupling β (and the
friction beside it) moves with it, and the σ said nothing of it (red team `coulomb+held_cart`
2902: β 12.7 ± 2.3 /s² for a true 27.3).

So the estimate's error is drawn as it arises: the estimated motion read again through the
encoder's lattice at `DRAWS` phases, with white noise of the reading's remaining scatter, and
estimated again (`held_motion`); each draw's difference e_k from the estimate is an input
error. Its effect on the parameters is the Gauss-Newton step of the fit with that input,

    Δθ_k = (J_kᵀJ_k)⁻¹ J_kᵀ (y - ŷ(θ; u + e_k)),

J_k the Jacobian of the carts' positions with the input u + e_k (read without the encoder
lattice, as their σ is, `fitting._std_through_lattice`): with the drawn input in the Jacobian
too, the step carries the coupling's shrinking by the input's error, not only the error's
first-order pull. The mean square Σ_k Δθ_k² / K is added to each parameter's variance. No I/O
here.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ident.diagnose.fitting import FitResult, without_lattice
from ident.diagnose.held_fit import held_motion, work_grid
from ident.diagnose.problem import FloatArray

#: Draws of the held reading's error (lattice phases spread over one quantum).
DRAWS = 8


@dataclasses.dataclass(frozen=True)
class HeldReading:
    """The held cart's `reading` (N,) m from the window's start, the free cart's `free` (N,)
    m, the sample period `dt` (s), the free cart's main mode `wn` (rad/s), the encoder's
    `quantum` (m, 0: none) and the `motion` (N,) m estimated from them (`held_motion`)."""

    reading: FloatArray
    free: FloatArray
    dt: float
    wn: float
    quantum: float
    motion: FloatArray


def read_held(reading: FloatArray, free: FloatArray, dt: float, wn: float, quantum: float) -> HeldReading:
    """The held cart's reading with its estimated motion (`held_fit.held_motion`)."""
    return HeldReading(reading, free, dt, wn, quantum, held_motion(reading, free, dt, wn, quantum))


def input_errors(held: HeldReading, decimation: int, seed: int = 0) -> list[FloatArray]:
    """`DRAWS` draws of the held input's error on a grid of every `decimation`-th sample,
    each (n,) m from the grid's first sample (see the module docstring)."""
    rng = np.random.default_rng(seed)
    x, q = held.motion, held.quantum
    scatter = float(np.var(held.reading - x)) - (q * q / 12.0 if q > 0 else 0.0)
    noise = float(np.sqrt(max(scatter, 0.0)))
    errors = []
    for k in range(DRAWS):
        shifted = x + (k + 0.5) / DRAWS * q
        read = q * np.round(shifted / q) - (shifted - x) if q > 0 else x.copy()
        read = read + rng.normal(0.0, noise, x.size)
        again = held_motion(read, held.free, held.dt, held.wn, q)
        errors.append(work_grid(again - x, decimation))
    return errors


def with_input_error(result: FitResult, dt: float, y: FloatArray, held: HeldReading,
                     decimation: int) -> FitResult:
    """`result` (fitted on `y` (n, carts) m at work steps of `dt` s, every `decimation`-th
    sample of the held reading) with the held input's error added to its parameters' σ; the
    encoder lattice's parameters and fixed ones keep theirs."""
    spec = result.spec
    measured = spec.held
    if measured is None or "held_cart_motion" not in spec.effects:
        return result
    bare, keep = without_lattice(spec)
    names = [n for n, k in zip(spec.names, keep) if k]
    free = np.array([i for i, n in enumerate(names) if n not in bare.fixed], dtype=int)
    theta = result.theta[keep]
    n = y.shape[0]
    steps = 1e-6 * np.maximum(np.abs(theta[free]), 1e-6)
    rows = np.repeat(theta[None, :], free.size + 1, axis=0)
    rows[np.arange(1, free.size + 1), free] += steps

    def step(error: FloatArray) -> FloatArray | None:
        drawn = dataclasses.replace(bare, held=measured[:n] + error)
        with np.errstate(all="ignore"):
            pred = drawn.predict(rows, dt, n).reshape(rows.shape[0], -1)
            jac = ((pred[1:] - pred[0]) / steps[:, None]).T
            misfit = y.ravel() - pred[0]
        if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(misfit))):
            return None
        return np.asarray(np.linalg.lstsq(jac, misfit, rcond=1e-12)[0], dtype=np.float64)

    # the step with the input as estimated: what a fit stopped short of its optimum would still
    # move (the final fit takes at most `fine.FINE_NFEV` evaluations), not the input's error
    own = step(np.zeros(n))
    if own is None:
        return result
    drawn = [step(e[:n]) for e in input_errors(held, decimation) if e.size >= n]
    moves = [m - own for m in drawn if m is not None]
    if not moves:
        return result
    variance = np.mean(np.stack(moves) ** 2, axis=0)
    std = result.std.copy()
    cols = np.flatnonzero(keep)[free]
    std[cols] = np.sqrt(std[cols] ** 2 + variance)
    return dataclasses.replace(result, std=std)


__all__ = ["DRAWS", "HeldReading", "input_errors", "read_held", "with_input_error"]
