"""Motion checks of a release run: rest level, noise level, which outputs move.

The release time itself is found by `ident.releases` (the one release estimator). Pure
numpy; time-major arrays (see `ident.data`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentValueError
from ident.physics.measures import encoder_quantum, noise_std

FloatArray = NDArray[np.float64]

#: The motion after a release must exceed this many noise standard deviations.
MIN_MOTION_SIGMAS = 20.0


def rest_window(n: int) -> slice:
    """The first samples, taken as the rest before the release (5 %, at least 5)."""
    return slice(0, max(5, n // 20))


def motion_amplitude(y: FloatArray) -> FloatArray:
    """Per-output largest deviation from the rest level, shape (n_out,)."""
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    rest = np.median(y2[rest_window(len(y2))], axis=0)
    return np.asarray(np.max(np.abs(y2 - rest), axis=0))


def check_motion(y: FloatArray) -> None:
    """Raise `IdentValueError` when no output moves clearly above its noise."""
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    amplitude = motion_amplitude(y2)
    sigma = noise_std(y2)
    ratio = float(np.max(amplitude / sigma))
    quantum = encoder_quantum(y2)
    if ratio < MIN_MOTION_SIGMAS or float(np.max(amplitude)) <= 3.0 * quantum:
        raise IdentValueError(
            "y", f"motion after a release (largest deviation ≥ {MIN_MOTION_SIGMAS:g} noise std)",
            f"largest deviation {float(np.max(amplitude)):.3g} m with noise std "
            f"{float(np.min(sigma)):.3g} m (no motion)")


def moving_outputs(y: FloatArray) -> list[int]:
    """Indices of the outputs that move clearly (≥ 20 noise std and > 3 quanta): a pinned
    cart's encoder reads a constant and is not one of them."""
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    amplitude = motion_amplitude(y2)
    sigma = noise_std(y2)
    return [j for j in range(y2.shape[1])
            if amplitude[j] >= MIN_MOTION_SIGMAS * sigma[j] and amplitude[j] > 3.0 * encoder_quantum(y2[:, [j]])]
