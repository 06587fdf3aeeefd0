"""The diagnosis record: what the linear simulation gets wrong, the named cause, the gain.

Written by `ident diagnose --json` and embedded in fit reports. Units are in field names
(`*_s` seconds on the run's exported time base, `*_m` metres, `*_hz` hertz). Model
parameters are maps `name -> value` whose names carry their units (`wn_rad_s`, `zeta`,
`coulomb_accel_m_s2`, `drag_per_m`, `cubic_per_m2_s2`, `quantum_m`, `mode_hz`, ...);
`parameter_std` holds one standard deviation for the same names where it was estimated.

Fit % is MATLAB `compare`'s `100 (1 - |y - y_hat| / |y - mean(y)|)` on the simulated (not
one-step) output, averaged over the measured outputs; `validation` says on which samples.
Bump `SCHEMA_VERSION` on any incompatible change.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field

from schemas.base import Record

#: The physical extensions `ident diagnose` can name (DESIGN.md "Effect names"), plus the
#: families added with forward selection: `presliding` (Dahl friction: the Coulomb friction's
#: pre-sliding stiffness), `static_friction` (a breakaway level above the kinetic one) and
#: `held_cart_motion` (the held cart's measured motion driving the free cart through the
#: coupling spring) and `rest_drift` (a slow drift of the free cart's rest: a held cart's
#: wander that no encoder read).
EffectName = Literal["coulomb_friction", "quadratic_drag", "cubic_stiffness", "quantization",
                     "coupled_mode", "presliding", "static_friction", "held_cart_motion", "rest_drift",
                     "none"]
#: How the peaks of |x - x_rest| decay, from the extrema of the measured run.
EnvelopeShape = Literal["constant_ratio", "constant_step", "amplitude_dependent", "undetermined"]

EFFECT_NAMES: tuple[str, ...] = ("coulomb_friction", "quadratic_drag", "cubic_stiffness",
                                 "quantization", "coupled_mode", "presliding", "static_friction", "held_cart_motion",
                                 "rest_drift",
                                 "none")


class ModelFit(Record):
    """One fitted model: its name, validation fit % and parameters (with 1-sigma where known).

    `fit_percent` is the mean over the outputs that move; `fit_percent_per_output` has None
    for an output that never moves (a held cart reading exactly 0: no fit % is defined).
    """

    model: str
    fit_percent: float
    fit_percent_per_output: list[float | None] = Field(default_factory=list)
    parameters: dict[str, float]
    parameter_std: dict[str, float] = Field(default_factory=dict)


class Candidate(Record):
    """One extension of the linear model (the first round of the forward selection).

    `fit_percent` is its whole-window fit %, `gain_points` that minus the baseline's.
    `lr_train` is `n ln(SSE_base / SSE_candidate)` on the whole window, `lr_validation` the
    same ratio of the blocked cross-validation costs (contiguous held-out blocks);
    `significant` says both exceed what noise explains (`threshold_*`) and the information
    criterion agrees.
    """

    effect: EffectName
    parameters: dict[str, float]
    parameter_std: dict[str, float] = Field(default_factory=dict)
    fit_percent: float
    gain_points: float
    extra_parameters: int = Field(ge=0)
    lr_train: float
    lr_validation: float
    threshold_train: float
    threshold_validation: float
    significant: bool
    note: str = ""


class EffectFit(Record):
    """One effect accepted by the forward selection, in the order of its own gain.

    `gain_points`: whole-window fit % gained when it was added to the model before it;
    `cv_ratio`: `n ln(CV_before / CV_after)` of the blocked cross-validation costs, against
    `cv_threshold` (what noise explains); `bic_drop`: decrease of the Bayesian information
    criterion. `material` is False for a real but immaterial effect (the misfit it removes is
    under a tenth of what the final model still misses, and it adds under 0.05 points):
    listed, never the headline.
    """

    effect: EffectName
    rank: int = Field(ge=1)
    step: int = Field(ge=1)
    parameters: dict[str, float]
    parameter_std: dict[str, float] = Field(default_factory=dict)
    gain_points: float
    cv_ratio: float
    cv_threshold: float
    bic_drop: float
    material: bool


class Evidence(Record):
    """Residual analysis of the linear baseline: what separates the candidates."""

    residual_rms_m: float
    noise_std_m: float
    whiteness_fraction_outside: float
    residual_is_white: bool
    residual_peak_hz: float
    residual_peak_to_baseline_ratio: float
    envelope_shape: EnvelopeShape
    envelope_peaks: int = Field(ge=0)
    envelope_step_m: float
    envelope_ratio: float
    frequency_drift_per_m2: float
    rest_offset_m: float
    stuck_for_s: float
    lattice_quantum_m: float | None = None
    lattice_coherence: float
    second_frequency_hz: float | None = None


class DiagnosisReport(Record):
    """The answer of `ident diagnose`: baseline, candidates, accepted effects, cause, gain.

    `effects` are every effect the forward selection accepted, ranked by their own gain;
    `cause` (the headline) is the largest material one (`none` when there is none);
    `extended` is the model with every accepted effect and its whole-window fit.
    """

    SCHEMA_VERSION: ClassVar[int] = 2

    schema_version: int = 2
    source: str = ""
    carts: int = Field(ge=1, le=2)
    sample_rate_hz: float
    release_time_s: float
    window_start_s: float
    window_end_s: float
    step_m: list[float]
    step_estimated: bool
    baseline: ModelFit
    candidates: list[Candidate]
    effects: list[EffectFit] = Field(default_factory=list)
    cause: EffectName
    extended: ModelFit
    gain_points: float
    corrected_linear: dict[str, float]
    evidence: Evidence
    validation: str
    explanation: str
    elapsed_s: float = Field(ge=0.0)
