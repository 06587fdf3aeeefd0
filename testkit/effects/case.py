"""A generated run: what the code under test may see (`Observed`) and the truth kept apart (`Truth`)."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from testkit.effects.rig import FloatArray


@dataclass(frozen=True)
class Observed:
    """What a user has and passes: times `t` (N,) s, positions `y` (N, k) m in the zeroed
    frame (each encoder reads 0 at the start of the record), and the number of carts of the
    model to fit (`carts`, 1 or 2; it can differ from k: a held cart's column, one encoder)."""

    t: FloatArray
    y: FloatArray
    carts: int


@dataclass(frozen=True)
class Truth:
    """What the generator hid.

    `family`: the drawn family (an effect name, `none`, or a pair `a+b`); `headline`: the
    effect a diagnosis must name as the cause (None for a pair: either of its effects);
    `effects`: every effect present (what a diagnosis must find); `parameters`: the hidden
    values under the names the diagnosis report uses (`coulomb_accel_m_s2`, `drag_per_m`,
    `cubic_per_m2_s2`, `quantum_m`, `mode_hz`, `zeta`, ...), each to be recovered;
    `details`: more facts that are not to be scored (static friction, masses, ...);
    `clean` (N, k): the positions before the sensor (no noise, no lattice); `immaterial`: the
    effects present but worth under 0.05 fit-% points (a fine encoder lattice): a diagnosis
    must list them and never make one the headline (a lone one leaves the headline `none`).
    """

    family: str
    headline: str | None
    effects: tuple[str, ...]
    parameters: dict[str, float]
    release_time_s: float
    release: str
    rate_hz: float
    noise_m: float
    clean: FloatArray
    details: dict[str, float] = field(default_factory=dict)
    immaterial: tuple[str, ...] = ()


@dataclass(frozen=True)
class Case:
    seed: int
    observed: Observed
    truth: Truth

    @property
    def n_samples(self) -> int:
        return int(self.observed.t.size)

    def noise_floor_percent(self) -> FloatArray:
        """Fit % (MATLAB `compare`) of the noise-free positions against the measured ones, per column:
        the best any model can reach on this run."""
        y, clean = self.observed.y, self.truth.clean
        spread = np.linalg.norm(y - y.mean(axis=0), axis=0)
        return np.asarray(100.0 * (1.0 - np.linalg.norm(y - clean, axis=0) / spread))


def write_csv(case: Case, path: Path) -> Path:
    """The run as `time_s,pos1_m[,pos2_m]` (what the code under test receives from a file)."""
    y = case.observed.y
    header = ["time_s"] + [f"pos{i + 1}_m" for i in range(y.shape[1])]
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for k in range(case.observed.t.size):
            writer.writerow([repr(float(case.observed.t[k]))] + [repr(float(v)) for v in y[k]])
    return path
