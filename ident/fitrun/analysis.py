"""Everything the lab asks of one run, computed once: pure (IdData in, `RunAnalysis` out).

For a run of lab case (`analyse_fits`, then `with_diagnosis`)
- `cart1` / `cart2` (the other cart pinned): the simple identification of the pulled cart
  with RK4 and with Euler (`ident.simple`), PEM of order 2 on that cart, the diagnosis;
- `both` (two free carts): PEM of order 4 on both outputs, the diagnosis of both carts.

The case comes from the data: a cart "moves" when its largest deviation from rest exceeds
`MOVING_SIGMAS` noise standard deviations and `MOVING_COUNTS` encoder counts, and is at least
`HELD_FRACTION` of the largest cart's (a held cart wanders); `FitSettings.carts` overrides
it (one cart: the pulled or most moving column; two: both). Each stage that fails is
recorded in `errors` (stage -> "expected …, got …" message) and the others still run;
`RunAnalysis.failed_reason` says whether anything usable is left. No I/O, no plotting.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from ident import progress
from ident.data import FloatArray, IdData, input_jumps, make_uniform
from ident.diagnose import Diagnosis, diagnose
from ident.diagnose.still import why_still
from ident.errors import IdentError, IdentValueError
from ident.fitrun.envelope import fit_envelope
from ident.model import Model
from ident.physics.measures import encoder_quantum
from ident.prediction_error import pem
from ident.release import motion_amplitude, noise_std
from ident.releases.record import HELD_FRACTION
from ident.simple import fit_simple
from schemas.diagnosis import DiagnosisReport
from schemas.fit import EnvelopeRec, LabCase, SimpleMethod

#: A cart moves when its largest deviation exceeds this many noise std and encoder counts (and
#: `HELD_FRACTION` of the largest cart's). (It had to exceed 5 mm: the 2023 open-loop 0.5 V
#: steps move their cart 4.5-4.7 mm, 255 counts, and `ident fit --input` refused them.)
MOVING_SIGMAS = 30.0
MOVING_COUNTS = 3.0

Method = Literal["rk4", "euler", "pem"]
NoiseModel = Literal["oe", "innovation"]


@dataclass(frozen=True)
class FitSettings:
    """What to fit. The defaults are the lab's: RK4, Euler and PEM, order 2 per cart.

    `carts` 1 or 2 overrides the case found from the motion; `order` overrides 2 per cart;
    the simple identification (RK4/Euler) runs for one cart driven by the release step only
    (`step_input` False: the input is a recorded column, e.g. a motor's control effort);
    `friction` fits the Euler simulation with dry friction (`fit_simple(..., friction=True)`).
    """

    methods: tuple[Method, ...] = ("rk4", "euler", "pem")
    carts: int | None = None
    order: int | None = None
    noise_model: NoiseModel = "oe"
    step_input: bool = True
    friction: bool = False

    def __post_init__(self) -> None:
        if self.carts not in (None, 1, 2):
            raise IdentValueError("carts", "1 or 2", repr(self.carts))
        if self.order is not None and self.order < 1:
            raise IdentValueError("order", "a model order >= 1", repr(self.order))
        unknown = [m for m in self.methods if m not in ("rk4", "euler", "pem")]
        if unknown or not self.methods:
            raise IdentValueError("methods", "some of rk4, euler, pem", repr(self.methods))


@dataclass(frozen=True)
class SimpleResult:
    """One simple identification: `G(s) = gain·wn² / (s² + 2ζwn s + wn²)` of one cart."""

    method: SimpleMethod
    output: int
    wn_rad_s: float
    zeta: float
    gain: float
    fit_percent: float
    y_hat: FloatArray
    coulomb_accel_m_s2: float | None = None
    wn_std: float = float("nan")
    zeta_std: float = float("nan")
    release_time_s: float | None = None
    converged: bool = True

    @property
    def tf_coefficients(self) -> tuple[list[float], list[float]]:
        wn2 = self.wn_rad_s ** 2
        return [self.gain * wn2], [1.0, 2.0 * self.zeta * self.wn_rad_s, wn2]


@dataclass(frozen=True)
class RunAnalysis:
    """The results of one run; `outputs` are the cart numbers of `data.y`'s columns."""

    case: LabCase
    data: IdData
    outputs: tuple[int, ...]
    simple: tuple[SimpleResult, ...] = ()
    pem: Model | None = None
    pem_y_hat: FloatArray | None = None
    diagnosis: DiagnosisReport | None = None
    diagnosis_traces: Diagnosis | None = None
    envelope: EnvelopeRec | None = None
    timings_s: dict[str, float] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    #: what the diagnosis fits (`ident.diagnose.diagnose`): positions (N, k) on `data.t`, a
    #: one-cart case's free cart first and then the other carts (a held cart's motion enters as
    #: an input, `diagnosis_columns`); None: `data.y`
    diagnosis_y: FloatArray | None = None
    #: `data.u` is a recorded force input (`FitSettings.step_input` False), which the diagnosis
    #: models too; else the release step
    forced: bool = False

    @property
    def release_time_s(self) -> float | None:
        """The release the data state (the finder's, a run's metadata), else the fitted one: a
        flicked cart is let go moving there; a model from rest would move it to the extreme."""
        if self.data.release_time_s is not None:
            return self.data.release_time_s
        if self.pem is not None and self.pem.release_time_s is not None:
            return float(self.pem.release_time_s)
        if self.diagnosis is not None:
            return float(self.diagnosis.release_time_s)
        return self.data.release_time_s

    @property
    def failed_reason(self) -> str | None:
        """Why the run counts as failed: no PEM model and no simple fit."""
        if self.pem is not None or self.simple:
            return None
        return "; ".join(f"{stage}: {msg}" for stage, msg in self.errors.items()) or \
            "nothing was fitted"


def detect_case(data: IdData) -> tuple[LabCase, tuple[int, ...]]:
    """The lab case and the carts (1-based) that move, from the data alone."""
    amplitude = motion_amplitude(data.y)
    floor = np.maximum(MOVING_SIGMAS * noise_std(data.y), MOVING_COUNTS * encoder_quantum(data.y))
    moving = tuple(j + 1 for j in range(data.n_outputs)
                   if amplitude[j] > floor[j] and amplitude[j] >= HELD_FRACTION * float(np.max(amplitude)))
    if not moving:
        raise IdentValueError("run", "a cart that moves after the release",
                              f"largest deviation {float(np.max(amplitude)):.3g} m (no motion)")
    if len(moving) == 2:
        return "both", (1, 2)
    return ("cart1" if moving == (1,) else "cart2"), moving


def _timed(stage: str, timings: dict[str, float], errors: dict[str, str],
           work: Callable[[], Any]) -> Any:
    progress.stage(stage)   # what a terminal shows now (a no-op unless a command opened a display)
    started = time.perf_counter()
    try:
        return work()
    except (IdentError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        errors[stage] = str(exc) or type(exc).__name__
        return None
    finally:
        timings[stage] = timings.get(stage, 0.0) + time.perf_counter() - started


def analyse(data: IdData, settings: FitSettings = FitSettings(),
            diagnose: bool = True) -> RunAnalysis:
    """Detect the case and run every fit the lab asks for on it (the diagnosis last)."""
    analysis = analyse_fits(data, settings)
    return with_diagnosis(analysis) if diagnose else analysis


def choose_case(data: IdData, carts: int | None) -> tuple[LabCase, tuple[int, ...]]:
    """The case and its carts: from the motion, or `carts` (1: the pulled cart when it
    moves, else the one that moves most; 2: both) when given."""
    if carts is None:
        return detect_case(data)
    if carts == 2:
        if data.n_outputs < 2:
            raise IdentValueError("carts", "two position columns for two carts",
                                  f"{data.n_outputs} column")
        return "both", (1, 2)
    if data.n_outputs == 1:
        return "cart1", (1,)
    amplitude = motion_amplitude(data.y)
    pulled = data.pulled_cart
    column = int(np.argmax(amplitude))
    if pulled is not None and pulled in (1, 2) and amplitude[pulled - 1] >= HELD_FRACTION * float(np.max(amplitude)):
        column = pulled - 1
    return ("cart1" if column == 0 else "cart2"), (column + 1,)


def case_samples(data: IdData, carts: tuple[int, ...]) -> IdData:
    """The samples the fits use: the columns of `carts` (1-based, in that order), on a uniform grid.

    A record with irregular stamps (the ECP Teensy's 1 and 2 ms steps) is resampled by
    `ident.make_uniform` (the note says how): every fit then runs on one grid, and the
    simulators take their fast uniform path.
    """
    columns = [c - 1 for c in carts]
    selected = data.select_outputs(columns) if columns != list(range(data.n_outputs)) else data
    return selected if selected.is_uniform() else make_uniform(selected)


def analyse_fits(data: IdData, settings: FitSettings = FitSettings()) -> RunAnalysis:
    """The case, the simple identifications and PEM (fast: well under a second)."""
    data = on_one_grid(data)
    case, moving = choose_case(data, settings.carts)
    columns = [c - 1 for c in moving]
    cart_data = case_samples(data, moving)
    diagnosed = diagnosis_columns(data, cart_data, columns)
    case, moving = _named(data, case, columns)
    timings: dict[str, float] = {}
    errors: dict[str, str] = {}
    simple: list[SimpleResult] = []
    if len(moving) == 1 and settings.step_input:
        for method in ("rk4", "euler"):
            if method not in settings.methods:
                continue
            result = _timed("simple", timings, errors,
                            lambda m=method: fit_simple_result(cart_data, m, moving[0],  # type: ignore[misc]
                                                               settings.friction and m == "euler"))
            if result is not None:
                simple.append(result)
    model = y_hat = None
    if "pem" in settings.methods:
        order = settings.order or 2 * len(moving)
        model = _timed("pem", timings, errors,
                       lambda: pem(cart_data, order, noise_model=settings.noise_model))
        y_hat = None if model is None else model.simulate(cart_data.u)
    analysis = RunAnalysis(case, cart_data, moving, tuple(simple), model, y_hat, timings_s=timings,
                           errors=errors, diagnosis_y=diagnosed, forced=not settings.step_input)
    return dataclasses.replace(analysis, envelope=envelope_of(analysis))


def diagnosis_columns(data: IdData, cart_data: IdData, columns: list[int]) -> FloatArray:
    """The diagnosis' positions (N, k) on `cart_data.t`: a one-cart case's free cart (column
    `columns[0]` of `data`) and then the other carts (held by a hand, their motion moves the
    free cart through the spring: the diagnosis takes it as an input, as `ident diagnose`
    does; a pinned cart that never moves is left out), or the case's own columns when there
    are no others or they do not share the case's grid."""
    others = [j for j in range(data.n_outputs) if j not in columns and why_still(data.y[:, j]) is None]
    if len(columns) == 1 and others:
        every = case_samples(data, tuple(j + 1 for j in columns + others))
        if every.t.shape == cart_data.t.shape and np.array_equal(every.t, cart_data.t):
            return every.y
    return cart_data.y


def on_one_grid(data: IdData) -> IdData:
    """`data` on a uniform grid when it carries a recorded input (more than one jump in `u`,
    e.g. a motor's 'Control Effort') on an irregular clock, else `data` unchanged.

    PEM resamples such a record for itself; the analysis must then hold the same grid (`u`
    resampled by zero-order hold with `y`, `ident.data.make_uniform`), or the model's free
    run, the envelope and the diagnosis would pair the fitted grid with the file's stamps.
    A step input on an irregular clock is kept as recorded: the step fitters take any stamps.
    """
    if data.is_uniform() or input_jumps(data.u).size <= 1:
        return data
    return make_uniform(data, "linear")


def _named(data: IdData, case: LabCase, columns: list[int]) -> tuple[LabCase, tuple[int, ...]]:
    """The case and carts by the carts the columns read (`IdData.cart_numbers`: a file whose
    only column is 'Encoder 2 Pos' is cart 2, not cart 1)."""
    numbers = data.cart_numbers()
    named = tuple(numbers[c] for c in columns)
    if len(named) == 1 and named[0] in (1, 2):
        return ("cart1" if named[0] == 1 else "cart2"), named
    return case, named if set(named) <= {1, 2} else tuple(c + 1 for c in columns)


def envelope_of(analysis: RunAnalysis) -> EnvelopeRec | None:
    """The peak envelope of a one-cart run, with both laws; None for two carts (they beat).

    The half-cycles are split about the median position after the release (a ring spends as
    long above its rest as below it); the rest itself is then estimated from the extremes.
    """
    data, release = analysis.data, analysis.release_time_s
    if analysis.case == "both" or release is None:
        return None
    after = data.y[data.t >= release, 0]
    if after.size < 3:
        return None
    return fit_envelope(data.t, data.y[:, 0], float(np.median(after)), release,
                        float(noise_std(data.y)[0]), output=analysis.outputs[0])


def with_diagnosis(analysis: RunAnalysis) -> RunAnalysis:
    """The analysis plus `ident.diagnose` (what the linear model misses; seconds)."""
    timings, errors = dict(analysis.timings_s), dict(analysis.errors)
    carts = 2 if analysis.case == "both" else 1
    traces = _timed("diagnose", timings, errors, lambda: _diagnose(analysis, carts))
    return dataclasses.replace(analysis, diagnosis=None if traces is None else traces.report,
                               diagnosis_traces=traces, timings_s=timings, errors=errors)


def _diagnose(analysis: RunAnalysis, carts: int) -> Diagnosis:
    data = analysis.data
    y = data.y if analysis.diagnosis_y is None else analysis.diagnosis_y
    return diagnose(data.t, y, carts=carts, source=data.name, u=data.u if analysis.forced else None)


def fit_simple_result(data: IdData, method: SimpleMethod, output: int, friction: bool = False) -> SimpleResult:
    """The simple identification (`ident.simple.fit_simple`; `friction`: Euler with dry
    friction) as a `SimpleResult`."""
    fit = fit_simple(data, method=method, friction=friction)
    y_hat = np.asarray(fit.simulate(data.u, data.t))
    return SimpleResult(method=method, output=output, wn_rad_s=float(fit.wn),
                        zeta=float(fit.zeta), gain=float(fit.gain),
                        fit_percent=float(fit.fit_percent[0]),
                        y_hat=y_hat.reshape(len(data.t), -1), coulomb_accel_m_s2=fit.friction,
                        wn_std=float(fit.std_errors.get("wn", float("nan"))),
                        zeta_std=float(fit.std_errors.get("zeta", float("nan"))),
                        release_time_s=float(fit.release_time_s), converged=bool(fit.success))


__all__ = ["MOVING_COUNTS", "MOVING_SIGMAS", "FitSettings", "Method", "NoiseModel", "RunAnalysis",
           "SimpleResult", "analyse", "analyse_fits", "case_samples", "choose_case", "detect_case",
           "diagnosis_columns", "envelope_of", "fit_simple_result", "on_one_grid", "with_diagnosis"]
