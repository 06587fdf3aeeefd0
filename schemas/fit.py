"""The fit report of one run: what `ident worker` publishes and writes.

Published on `keys.run_fit(bench, run_id)` (advanced publisher with a cache, so late
subscribers get it) and written as `<run_id>.fit/report.json` beside the figures.

`status` is one of:

- `fitting`: the claim a worker announces before it starts (`worker` names it). It is not
  a result: consumers that want results keep only `final` reports. A claim is void once
  its worker's liveliness token is gone.
- `withdrawn`: that worker takes its claim back (it lost the tie-break with another claim,
  or the run is not available yet: it will be claimed again).

Fencing: a claim carries `epoch`, one more than any claim seen for the run, so a worker that
takes over the run of a vanished (or paused) worker outranks it; a worker publishes a final
report only if no alive claim of a higher epoch and no final report from another worker has
been seen. `run_digest` is the `RunFinished.digest()` of the run fitted: a final report counts
as done only when it matches the daq's record of the run.
- `ok`: the fits ran; the result fields are filled in. While `pending` names stages still
  running (`diagnosis`, `figures`), the report is a partial result published early (the
  transfer functions within a second of the run's end) and still counts as the worker's
  claim; the same worker then publishes the complete report (`pending` empty).
- `failed`: the run could not be fitted; `reason` says why ("expected X, got Y" style).
  Whatever was computed before the failure is still reported.

Transfer functions are continuous-time, from the release step input `r` (metres of pull,
`r = d·H(t - t_r)`) to each cart position (metres), as coefficient lists of `s`, highest
power first. `wn_rad_s` is in rad/s, `zeta` dimensionless, fit % as MATLAB `compare`:
`100 (1 - |y - y_hat| / |y - mean(y)|)` on the simulated output.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from schemas import keys
from schemas.base import Record
from schemas.diagnosis import DiagnosisReport

FitStatus = Literal["fitting", "withdrawn", "ok", "failed"]
LabCase = Literal["cart1", "cart2", "both"]
SimpleMethod = Literal["rk4", "euler"]

#: The lab cases, in the handout's order.
LAB_CASES: tuple[LabCase, ...] = ("cart1", "cart2", "both")


class TransferFunctionRec(Record):
    """`G(s) = num(s) / den(s)`, coefficients highest power of `s` first."""

    output: int = Field(ge=1, le=2, description="cart number whose position is the output")
    num: list[float]
    den: list[float]
    text: str = ""

    @model_validator(mode="after")
    def _nonempty(self) -> TransferFunctionRec:
        if not self.num or not self.den:
            raise ValueError(f"expected non-empty num and den, got {self.num} / {self.den}")
        return self


class ModeRec(Record):
    """One oscillatory mode (pole pair) of a model."""

    wn_rad_s: float
    zeta: float
    wn_std: float | None = Field(default=None, description="standard error of wn_rad_s")
    zeta_std: float | None = Field(default=None, description="standard error of zeta")


class SimpleFitRec(Record):
    """Simple identification (handout Part 2): the physical model fitted by simulation."""

    method: SimpleMethod
    output: int = Field(ge=1, le=2)
    tf: TransferFunctionRec
    wn_rad_s: float
    zeta: float
    gain: float
    fit_percent: float
    coulomb_accel_m_s2: float | None = None
    wn_std: float | None = None
    zeta_std: float | None = None
    release_time_s: float | None = None
    converged: bool = True


class PemFitRec(Record):
    """Prediction-error model (Parts 3-4): order 2 for one cart, 4 for two carts."""

    order: int = Field(ge=1)
    tfs: list[TransferFunctionRec]
    modes: list[ModeRec]
    fit_percent: list[float]
    outputs: list[int]
    dc_gain: list[float] = Field(default_factory=list, description="per output, m per m of pull")
    release_time_s: float | None = None
    noise_model: Literal["oe", "innovation"] = "oe"
    converged: bool = True
    stable: bool = Field(default=True, description="every mode has zeta > 0 (False: not a model of the carts)")
    message: str = ""


class EnvelopeRec(Record):
    """The half-cycle peaks of one free cart and the two reference laws fitted to them: the one
    definition of an envelope (`ident.fitrun.envelope.fit_envelope` returns it).

    Peaks `peak_m` (m) of `|x - rest_m|` at `t_s` (s); `period_s` the mean cycle.
    Coulomb (dry friction, a constant loss per cycle): `A(t) = coulomb_a0_m -
    coulomb_slope_m_s·(t - t_s[0])`; viscous (a constant ratio per cycle):
    `A(t) = viscous_a0_m·exp(-viscous_rate_1_s·(t - t_s[0]))`; `*_rms_m` the RMS misfits on
    the peaks; both at once: `A_{k+1} = mixed_ratio_per_half·A_k - mixed_loss_m_per_half`.
    """

    output: int = Field(ge=1, le=2)
    t_s: list[float]
    peak_m: list[float]
    rest_m: float
    period_s: float
    coulomb_a0_m: float
    coulomb_slope_m_s: float
    coulomb_rms_m: float
    viscous_a0_m: float
    viscous_rate_1_s: float
    viscous_rms_m: float
    mixed_ratio_per_half: float = Field(description="both at once: A_{k+1} = q A_k - b, q")
    mixed_loss_m_per_half: float = Field(description="both at once: A_{k+1} = q A_k - b, b (m)")

    @property
    def coulomb_loss_per_cycle_m(self) -> float:
        """The constant amount dry friction takes off the amplitude each cycle (m)."""
        return self.coulomb_slope_m_s * self.period_s

    @property
    def viscous_ratio_per_cycle(self) -> float:
        """The constant ratio of successive peaks one cycle apart under viscous damping."""
        return math.exp(-self.viscous_rate_1_s * self.period_s)

    @property
    def better_law(self) -> Literal["coulomb", "viscous"]:
        """`coulomb` (straight line) or `viscous` (exponential): the smaller misfit."""
        return "coulomb" if self.coulomb_rms_m < self.viscous_rms_m else "viscous"


class FitTimings(Record):
    """Wall time of each stage, seconds."""

    load_s: float = 0.0
    simple_s: float = 0.0
    pem_s: float = 0.0
    diagnose_s: float = 0.0
    figures_s: float = 0.0
    total_s: float = 0.0


class FitReport(Record):
    """The fit report of one run (see the module docstring for `status`)."""

    bench: str
    run_id: str
    worker: str
    status: FitStatus
    reason: str | None = None
    case: LabCase | None = None
    release_time_s: float | None = None
    sample_rate_hz: float | None = None
    duration_s: float | None = None
    simple: list[SimpleFitRec] = Field(default_factory=list)
    pem: PemFitRec | None = None
    diagnosis: DiagnosisReport | None = None
    envelope: EnvelopeRec | None = None
    figures: list[str] = Field(default_factory=list)
    pending: list[Literal["diagnosis", "figures"]] = Field(default_factory=list)
    timings: FitTimings = Field(default_factory=FitTimings)
    fitted_utc: str | None = None
    software_version: str = ""
    notes: list[str] = Field(default_factory=list, description="what the loader noticed")
    extra: dict[str, Any] = Field(default_factory=dict)
    epoch: int = Field(default=0, ge=0, description="the claim's fencing epoch")
    run_digest: str | None = Field(default=None, max_length=64,
                                   description="RunFinished.digest() of the run fitted")

    @field_validator("bench", "run_id", "worker")
    @classmethod
    def _safe_name(cls, value: str, info: ValidationInfo) -> str:
        # these become Zenoh key chunks and directory names (`<bench>/<run_id>.fit/`)
        return keys.check_name(str(info.field_name), value)

    @property
    def final(self) -> bool:
        """True for a complete result (`ok` or `failed`, nothing pending)."""
        return self.status in ("ok", "failed") and not self.pending

    @property
    def has_results(self) -> bool:
        """True for a partial or complete result (not a claim or a withdrawal)."""
        return self.status in ("ok", "failed")

    @model_validator(mode="after")
    def _reason_when_failed(self) -> FitReport:
        if self.status == "failed" and not self.reason:
            raise ValueError("expected a reason for a failed fit report, got none")
        if self.pending and self.status != "ok":
            raise ValueError(f"expected pending stages only on an ok report, got {self.status}")
        return self


__all__ = [
    "LAB_CASES",
    "EnvelopeRec",
    "FitReport",
    "FitStatus",
    "FitTimings",
    "LabCase",
    "ModeRec",
    "PemFitRec",
    "SimpleFitRec",
    "SimpleMethod",
    "TransferFunctionRec",
]
