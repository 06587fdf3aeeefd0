"""What the carts' readings leave in the parameters: a σ for a reading error that is no white
noise.

The Gauss-Newton σ of a fit (`fitting._std`; through the continuous prediction where the model
reads through its lattice, `fitting._std_through_lattice`) counts the residual as white: every
sample's error independent, of the residual's variance, the lattice's share q²/12 (Widrow). Two
things break that on the records a diagnosis is made of:

- a cart with dry friction that sticks sits on ONE level of its encoder for the rest of the
  window: its reading error there is one number, uniform on ±q/2, repeated on every stuck
  sample (noise after the encoder scatters about it, it does not average it away). The fit takes
  the stuck position where the level is, and the parameters that set where the cart stops (the
  friction, the held cart's gain β beside it, the rest) move with that one error, while the
  residual there is the noise alone: the residual does not show it;
- what the model misses (a held cart's input estimated from its reading, a breakaway chosen on
  a grid) leaves a residual with slow structure, most of it near the carts' modes, where the
  parameters' sensitivities are too; counted white, its effect is divided by the number of
  samples rather than by the number of independent stretches.

Red team `coulomb+held_cart` 3404 (a 0.52 mm lattice with noise after it, the free cart stuck
10 of 12 s): β -28 % reported ± 6.3 % (4.4σ); over 5700-5729 the rms of (estimate - truth)/σ of
β was 1.7, of the friction 2.3.

Both are counted as a sandwich about the least-squares gain G = (JᵀJ + RᵀR)⁻¹ Jᵀ at the final
fit, J the Jacobian of the carts' positions (the model read without its lattice), R the rest
drift's penalty root (`drift.drift_penalty`) if the model has one:

- `lattice_variance`: the fitted model's continuous positions x̂ read again through the
  lattice at `PHASES` phases spread over one quantum (a phase per cart), with white noise
  before the encoder (the residual's variance beyond the lattice's q²/12 and the noise after
  it: a dither) and after it (`after`, from the lattice's coherence, 0 on exact levels); each
  draw's error e_k = read_k - x̂ moves the parameters by G e_k, and Σ_k (G e_k)² / K is their
  variance. Where the carts cross many levels it is the Gauss-Newton one; where a cart sticks
  it carries the one shared error;
- `spectral_variance`: diag(G Σ Gᵀ), Σ the covariance of the residual of the model as it
  reads (through its lattice, when it has one: a staircase's error is the lattice's, not a
  misfit) as a stationary series per cart, its spectrum the periodogram averaged over
  `SMOOTH_BINS` bins (Daniell; a white residual gives the Gauss-Newton variance back). Taken
  from the continuous positions' residual instead, a 1.4 mm lattice's slow staircase error made
  the σ of β ten times the Gauss-Newton one (`tests/ident/test_diagnose_held_lattice.py` seed 1).

Each carts' parameter's variance is the largest of the Gauss-Newton one and these two (they
count the same white noise, each with what the other does not see: the residual cannot show a
stuck level's error, the lattice's draws know nothing of the model's misfit); a breakaway ratio,
chosen on a grid, keeps its own. No I/O here.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ident.diagnose.drift import drift_penalty
from ident.diagnose.fitting import FitResult, continuous_jacobian, without_lattice
from ident.diagnose.problem import FloatArray

#: Phases of the lattice (per cart, shuffled between carts) at which the positions are read again.
PHASES = 32
#: Bins (of the residual's DFT zero-padded to at least twice its length) its periodogram is
#: averaged over (`spectral_variance`).
SMOOTH_BINS = 9


def with_reading_error(result: FitResult, dt: float, y: FloatArray, quantum: float, after: float) -> FitResult:
    """`result` (fitted on `y` (n, carts) m at steps of `dt` s) with its carts' parameters' σ
    counting a residual that is not white and, with `quantum` > 0, the reading error an
    encoder lattice of `quantum` (m) read with noise `after` (m) after it makes on the fitted
    positions (see the module docstring); the lattice's own parameters, a breakaway ratio and
    fixed ones keep theirs."""
    spec = result.spec
    bare, keep = without_lattice(spec)
    names = [n for n, k in zip(spec.names, keep) if k]
    chosen = set(spec.names_of("static_friction"))   # on a grid: no finite difference moves it
    free = np.array([i for i, n in enumerate(names) if n not in bare.fixed and n not in chosen], dtype=int)
    if free.size == 0:
        return result
    theta = result.theta[keep]
    n = y.shape[0]
    position, diff = continuous_jacobian(bare, theta, free, 1e-6 * np.maximum(np.abs(theta[free]), 1e-6), dt, n)
    jac = diff.reshape(free.size, -1).T
    resid = y - position
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(resid))):
        return result
    m, p = jac.shape
    scatter = float(np.sum(resid ** 2)) / max(m - p, 1)
    normal = jac.T @ jac
    root = drift_penalty(bare, free, scatter)
    if root is not None:
        normal = normal + root.T @ root
    gain = np.linalg.pinv(normal) @ jac.T
    # what the model misses beyond its own lattice: the residual of the model as it reads (a
    # staircase's error is the lattice's, counted by its draws, not a misfit)
    with np.errstate(all="ignore"):
        missed = y - spec.predict(result.theta[None, :], dt, n)[0] if "quantization" in spec.effects else resid
    if not np.all(np.isfinite(missed)):
        missed = resid
    variance = spectral_variance(gain, missed, float(np.sum(missed ** 2)) / max(m - p, 1))
    if quantum > 0:
        before = float(np.sqrt(max(scatter - quantum * quantum / 12.0 - after * after, 0.0)))
        variance = np.maximum(variance, lattice_variance(gain, position, quantum, before, after))
    std = result.std.copy()
    cols = np.flatnonzero(keep)[free]
    std[cols] = np.sqrt(np.maximum(std[cols] ** 2, variance))
    return dataclasses.replace(result, std=std)


def reading_errors(position: FloatArray, quantum: float, before: float, after: float,
                   seed: int = 0) -> list[FloatArray]:
    """`PHASES` draws of the error (n, c) m of reading `position` (n, c) m through a lattice of
    `quantum` (m) at phases spread over one quantum (shuffled between the carts), with white
    noise of `before` (m) added before the encoder and of `after` (m) after it."""
    rng = np.random.default_rng(seed)
    carts = position.shape[1]
    phases = (np.arange(PHASES) + 0.5) / PHASES * quantum
    order = np.stack([rng.permutation(PHASES) for _ in range(carts)], axis=1)   # (PHASES, carts)
    errors = []
    for k in range(PHASES):
        phase = phases[order[k]]
        shifted = position + phase + rng.normal(0.0, before, position.shape)
        read = quantum * np.round(shifted / quantum) - phase + rng.normal(0.0, after, position.shape)
        errors.append(read - position)
    return errors


def lattice_variance(gain: FloatArray, position: FloatArray, quantum: float, before: float,
                     after: float) -> FloatArray:
    """(p,) the mean square of `gain` (p, n c) times each of `reading_errors` of `position`
    (n, c) m (see the module docstring)."""
    moves = np.stack([gain @ e.ravel() for e in reading_errors(position, quantum, before, after)])
    out: FloatArray = np.mean(moves ** 2, axis=0)
    return out


def spectral_variance(gain: FloatArray, resid: FloatArray, scatter: float) -> FloatArray:
    """(p,) diag(G Σ Gᵀ), G = `gain` (p, n c), Σ the covariance of the residual `resid` (n, c)
    as a stationary series per cart: its periodogram (zero-padded to at least twice its length,
    so no lag wraps) averaged over `SMOOTH_BINS` bins, scaled so that its variance is `scatter`
    (the residual's per degree of freedom): Σ_f |Ĝ_i(f)|² S(f) / size."""
    from scipy.ndimage import uniform_filter1d  # deferred: keeps `import ident` fast
    n, carts = resid.shape
    g = gain.reshape(gain.shape[0], n, carts)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    out = np.zeros(gain.shape[0])
    for c in range(carts):
        r = resid[:, c] - np.mean(resid[:, c])
        power = uniform_filter1d(np.abs(np.fft.fft(r, size)) ** 2, SMOOTH_BINS, mode="wrap")
        power *= scatter / max(float(np.mean(power)), 1e-300)
        out += (np.abs(np.fft.fft(g[:, :, c], size, axis=1)) ** 2) @ power / size
    return out


__all__ = ["PHASES", "SMOOTH_BINS", "lattice_variance", "reading_errors", "spectral_variance",
           "with_reading_error"]
