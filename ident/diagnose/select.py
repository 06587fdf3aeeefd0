"""Is a candidate's gain more than noise explains? Fit % and likelihood-ratio tests.

With Gaussian noise of unknown variance, the likelihood ratio of two nested output-error
models on n residuals is `LR = n ln(SSE_base / SSE_cand)`, asymptotically χ² with as many
degrees of freedom as extra parameters when the extension is absent. An effect is called
only when BOTH hold:

- training: LR_train > χ²_p(1 - 1e-4) (plus 2 ln(N/2) look-elsewhere for a searched
  frequency), so the fitted parameters explain more than noise;
- validation (held-out samples, not used by any fit): LR_val > χ²_p(1 - 1e-3), so the gain
  is real on data the fit did not see.

Among called effects the largest LR_val wins; none called -> `none`. No I/O here.
"""

from __future__ import annotations

import numpy as np
import scipy.stats
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

ALPHA_TRAIN = 1e-4
ALPHA_VALIDATION = 1e-3


def fit_percent(y: FloatArray, y_hat: FloatArray) -> list[float]:
    """MATLAB compare: 100 (1 - |y - ŷ| / |y - mean y|) per output column of (N, n_out)."""
    num = np.linalg.norm(y - y_hat, axis=0)
    den = np.linalg.norm(y - y.mean(axis=0), axis=0)
    return [float(100.0 * (1.0 - a / b)) if b > 0 else float("nan") for a, b in zip(num, den)]


def likelihood_ratio(n: int, sse_base: float, sse_cand: float) -> float:
    return float(n * np.log(max(sse_base, 1e-300) / max(sse_cand, 1e-300)))


def thresholds(extra: int, searched_frequency: bool, n: int) -> tuple[float, float]:
    """(training, validation) LR thresholds for `extra` parameters."""
    train = float(scipy.stats.chi2.ppf(1 - ALPHA_TRAIN, extra))
    val = float(scipy.stats.chi2.ppf(1 - ALPHA_VALIDATION, extra))
    if searched_frequency:
        train += 2.0 * float(np.log(max(n / 2.0, 1.0)))
    return train, val
