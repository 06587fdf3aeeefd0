"""Discrete-to-continuous conversion (zero-order hold), the handout's `d2c`.

python-control 0.10.2 has `sample_system` (c2d) but no d2c. For a zoh model
x[k+1] = Φ x[k] + Γ u[k] sampled at Ts from x' = A x + B u,

    [[Φ, Γ], [0, I]] = expm([[A, B], [0, 0]] Ts),

so A and B come from the principal matrix logarithm of the augmented matrix:
[[A, B], [0, 0]] = logm([[Φ, Γ], [0, I]]) / Ts. This exists (real) when Φ has no eigenvalue
on the negative real axis — poles below the Nyquist frequency; C and D are unchanged.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentValueError

FloatArray = NDArray[np.float64]


def d2c_zoh(phi: FloatArray, gamma: FloatArray, ts: float) -> tuple[FloatArray, FloatArray]:
    """Continuous (A, B) of the zoh-discretised (Φ (n, n), Γ (n, m)) at sample time `ts` (s)."""
    from scipy.linalg import logm  # deferred: keeps `import ident` fast
    phi = np.atleast_2d(np.asarray(phi, dtype=np.float64))
    gamma = np.asarray(gamma, dtype=np.float64).reshape(phi.shape[0], -1)
    eig = np.linalg.eigvals(phi)
    if np.any((np.abs(eig.imag) < 1e-12) & (eig.real <= 0.0)):
        raise IdentValueError("Φ", "no eigenvalue on the negative real axis (poles below Nyquist)",
                              np.round(eig, 6).tolist())
    n, m = gamma.shape
    aug = np.zeros((n + m, n + m))
    aug[:n, :n] = phi
    aug[:n, n:] = gamma
    aug[n:, n:] = np.eye(m)
    log = np.real_if_close(logm(aug), tol=1e6) / ts
    return np.asarray(np.real(log[:n, :n])), np.asarray(np.real(log[:n, n:]))


def c2d_zoh(a: FloatArray, b: FloatArray, ts: float) -> tuple[FloatArray, FloatArray]:
    """(Φ, Γ) of x' = A x + B u held constant over each sample of `ts` seconds."""
    from scipy.linalg import expm  # deferred: keeps `import ident` fast
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    b = np.asarray(b, dtype=np.float64).reshape(a.shape[0], -1)
    n, m = b.shape
    aug = np.zeros((n + m, n + m))
    aug[:n, :n] = a * ts
    aug[:n, n:] = b * ts
    e = expm(aug)
    return e[:n, :n], e[:n, n:]
