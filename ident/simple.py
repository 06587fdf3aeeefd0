"""Simple identification (the lab's Part 2): fit the physical single-cart model by simulation.

Model, in the zeroed frame, let go at t_r with pull U (m) and velocity v0 (m/s):

    x'' + 2ζ wn x' + wn² (x - g U H(t - t_r)) [+ f sign(x')] = 0,   x(t_r) = 0, x'(t_r) = v0,
    y = o + x + e,

simulated on the sample grid by RK4 or explicit Euler (`ident.physics.steppers`: the handout's
state-space recursion from the initial conditions), parameters p = (wn, ζ, g, t_r, o[, f], v0)
fitted by minimising the output error Σ (y - ŷ(p))² with
`scipy.optimize.least_squares` (finite-difference Jacobian on scaled parameters). Start
values come from the data: t_r from the onset of the motion, g from the final level, the
damped period from the zero crossings of y - y_final and σ = ζ wn from the logarithmic
decrement of the successive extrema. The release time stays a continuous parameter: the
simulation takes one partial step from t_r to the first sample after it.

Two releases (`initial_state`): a pull-hold-release lets the cart go from rest (v0 = 0, t_r
fitted); a flick lets it go moving, so the model starts at the release the data state from the
cart's position there (o) with an estimated v0, and t_r is not fitted (any point of a free
trajectory is a start from which the same curve follows). v0 = 0 is the release from rest.

The gain g is the fitted travel to the spring's rest over the stated pull U: g U = rest - o.
The DC gain of X(s)/R(s) is not identifiable from a free response alone (the rest level is);
with the lab's known pull (the hold at -d) g checks the pull and the encoder's scale; with a
raw record's pull, measured from the same record (its rest less the level at the release,
`ident.releases.release_step`), g ≈ 1 says the fitted rest is the record's, nothing more.

Euler's bias is the point of the lab: its amplitude grows by √(1 + (wn h)²) per step, so the
fitted ζ comes out too large; `substeps` shrinks h.

With dry friction (`method="euler", friction=True`) that bias would be the fit's (ζ 113 % off
on a clean 50 Hz run at the sample step, 3.6 % at 40 sub-steps), so the parameters come from
the physics' converged simulation instead (`ident.physics.simulate_free`, stick included, on a
grid with h·wn ≤ 0.01: position error ~1e-5 of the pull, parameters within 1 %), and the
handout's Euler recursion at the sample step, with the fitted parameters, is kept beside it
for display (`SimpleFit.euler_display`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ident import summary
from ident.comparison import fit_percent
from ident.data import IdData, input_jumps
from ident.errors import FitFailed, IdentValueError
from ident.physics.free import NonlinearTerms, simulate_free
from ident.physics.steppers import Method, euler_coulomb, linear_step_response
from ident.release import check_motion, moving_outputs
from ident.simple_start import envelope_friction, euler_zeta, release_state, sample_step, start_values, swing_floor

FloatArray = NDArray[np.float64]
InitialState = Literal["auto", "rest", "estimate"]
PARAMETER_NAMES = ("wn", "zeta", "gain", "release_time_s", "offset", "friction", "release_velocity")
#: h·wn of the fine grid the dry-friction model is simulated on (converged: see the docstring).
FINE_H_WN = 0.01
#: ... and at most this many fine steps per sample after the release.
FINE_PER_SAMPLE = 64
#: The fitted release stays within this many start-value periods of the given one.
RELEASE_PERIODS = 0.25
#: `initial_state="auto"` keeps the release from rest unless the estimated state explains the
#: data better by N ln(cost_rest / cost_estimate) above this (χ², 1 degree of freedom, α = 1e-3;
#: both models have as many parameters).
CHOICE_CHI2 = 10.83

__all__ = ["InitialState", "SimpleFit", "coulomb_response", "euler_zeta", "fit_simple", "release_bounds",
           "start_values", "swing_floor"]


@dataclass(frozen=True)
class SimpleFit:
    """Fitted single-cart model. `friction` in m/s² (Mf/m = μ g), None when not fitted.

    With friction, `y_hat` is the converged simulation the parameters come from and
    `euler_display` (N, 1) the handout's Euler recursion at the sample step (`substeps`
    sub-steps) with the same parameters, for showing Euler's drift; None without friction.

    `std_errors` maps parameter names to standard errors from s²(JᵀJ)⁻¹; `covariance` is in
    the order of `names`. `y_hat` (N, 1) is the simulated output on the time base `t`.
    """

    wn: float
    zeta: float
    gain: float
    release_time_s: float
    offset: float
    friction: float | None
    method: Method
    substeps: int
    names: tuple[str, ...]
    covariance: FloatArray
    std_errors: dict[str, float]
    fit_percent: tuple[float, ...]
    residuals: FloatArray
    input_delay_s: float
    t: FloatArray
    y_hat: FloatArray
    nfev: int
    success: bool
    message: str
    euler_display: FloatArray | None = None
    release_velocity: float = 0.0
    initial_state: Literal["rest", "estimate"] = "rest"

    def summary_rows(self) -> list[tuple[str, str]]:
        """The labelled lines of `repr` and `_repr_html_` (arrays stay in the attributes)."""
        def value(name: str, unit: str = "") -> str:
            return summary.with_std(getattr(self, name), self.std_errors.get(name, float("nan")), unit=unit)

        rows = [("wn", value("wn", "rad/s")), ("zeta", value("zeta")), ("gain", value("gain"))]
        if self.friction is not None:
            rows.append(("friction", value("friction", "m/s²")))
        start = ("from rest" if self.initial_state == "rest"
                 else f"the data's, with velocity {self.release_velocity:.4g} m/s (estimated)")
        rows += [("release", f"{self.release_time_s:.4f} s, {start}"),
                 ("fit (simulation)", summary.percents(self.fit_percent)),
                 ("status", f"{'converged' if self.success else 'NOT converged'}, {self.nfev} evaluations: "
                            + self.message)]
        return rows

    def _title(self) -> str:
        return f"Physical single-cart fit ({self.method}, {self.substeps} substep(s))"

    def __repr__(self) -> str:
        return summary.text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary.html_table(self._title(), self.summary_rows())

    def simulate(self, u: ArrayLike, t: ArrayLike | None = None) -> FloatArray:
        """Simulated y (N, 1) for a step input `u` on time base `t` (default: the fitted data's)."""
        t_arr = self.t if t is None else np.asarray(t, dtype=np.float64)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        jumps = np.flatnonzero(np.diff(u_arr) != 0.0)
        if jumps.size != 1:
            raise IdentValueError("u", "a single step (the release)", f"{jumps.size} changes")
        release = float(t_arr[jumps[0] + 1]) + self.input_delay_s
        params = np.array([self.wn, self.zeta, self.gain, release, self.offset, self.friction or 0.0,
                           self.release_velocity])
        y = _response(params, t_arr, float(u_arr[-1] - u_arr[0]), self.method, self.substeps,
                      self.friction is not None)
        return y[:, None]


def _response(p: FloatArray, t: FloatArray, amplitude: float, method: Method, substeps: int,
              with_friction: bool) -> FloatArray:
    """y (N,) of the model of the module docstring; p = (wn, ζ, g, t_r, o, f, v0)."""
    wn, zeta, gain, t_r, offset, friction, velocity = p
    if with_friction:
        if method != "euler":
            raise IdentValueError("method", "'euler' for the dry-friction model", method)
        return offset + coulomb_response(wn, zeta, friction, gain * amplitude, t, t_r, velocity)
    A = np.array([[0.0, 1.0], [-wn * wn, -2.0 * zeta * wn]])
    B = np.array([[0.0], [wn * wn]])
    grid, skip = _grid_from(t, t_r)
    initial = np.array([0.0, velocity], dtype=np.float64)
    return offset + linear_step_response(A, B, grid, t_r, gain * amplitude, method, substeps, initial)[skip:, 0]


def _grid_from(t: FloatArray, release_time_s: float) -> tuple[FloatArray, int]:
    """The time base (s) to simulate on and how many leading samples to drop: `t` itself, or,
    for a release before the first sample (a window that starts after the release), `t` with
    sample steps prepended back past the release. Without them the stepper would take one step
    of t[0] - t_r, and Euler's single step from rest leaves the cart where it was."""
    h = sample_step(t)
    if release_time_s >= t[0] or not h > 0.0 or not np.isfinite(release_time_s):
        return t, 0
    k = int(np.ceil((t[0] - release_time_s) / h))
    if k > t.size:   # a release this far out is refused after the fit (`release_bounds`)
        return t, 0
    return np.concatenate([t[0] - h * np.arange(k, 0, -1, dtype=np.float64), t]), k


def coulomb_response(wn: float, zeta: float, friction: float, r: float, t: FloatArray,
                     release_time_s: float, velocity: float = 0.0) -> FloatArray:
    """Positions (N,) of x'' + 2ζwn x' + wn² (x - r) + f sign(x') = 0 (static = kinetic f, m/s²),
    at 0 until t_r and let go there with velocity `velocity` (m/s; 0: from rest): the physics'
    free response on a uniform grid from t_r with h·wn ≤ FINE_H_WN (or `FINE_PER_SAMPLE` steps
    a sample, the coarser), linearly interpolated at the samples (error ≈ (h wn)² r / 8)."""
    t = np.asarray(t, dtype=np.float64)
    out = np.zeros(t.size)
    after = t > release_time_s
    if not np.any(after) or not (np.isfinite(wn) and wn > 0.0):
        return out
    tau = t[after] - release_time_s
    # at most FINE_PER_SAMPLE steps a sample: a fit running through a wn the samples cannot
    # show (wn h > 0.64) needs no finer grid, and it bounds each simulation's cost
    n = min(int(np.ceil(tau[-1] * wn / FINE_H_WN)), FINE_PER_SAMPLE * tau.size) + 2
    h = tau[-1] / (n - 1)
    terms = NonlinearTerms(friction_m_s2=np.array([[abs(friction)]]))
    deviation = simulate_free(np.array([[wn, zeta]]), np.array([[-r, velocity]]), h, n, 1, terms)[0, :, 0]
    out[after] = r + np.interp(tau, h * np.arange(n), deviation)
    return out


def fit_simple(data: IdData, method: Method = "rk4", *, friction: bool = False, substeps: int = 1,
               output: int = 0, fit_release: bool = True, initial_state: InitialState = "auto") -> SimpleFit:
    """Fit wn, ζ, gain, offset, the release (and dry friction f, Euler only) of one cart.

    `output` picks the column of `data.y`; `data.u` gives the pull amplitude U.
    `initial_state`: "rest" releases the cart from rest at a fitted t_r (a pull-hold-release;
    `fit_release=False` holds t_r at `data.release_time_s`, required then); "estimate" lets it
    go at the stated release (`data.release_time_s`, else where u steps) from its position
    there with an estimated velocity v0 (a flick; t_r is not identifiable then: any point of
    the trajectory is a start); "auto" fits both when the data state a release and keeps the
    release from rest unless the estimate explains the data better than noise would
    (`CHOICE_CHI2`), from rest only when they do not.
    """
    if method not in ("rk4", "euler"):
        raise IdentValueError("method", "'rk4' or 'euler'", method)
    if friction and method != "euler":
        raise IdentValueError("method", "'euler' when friction=True (the Coulomb model)", method)
    if initial_state not in ("auto", "rest", "estimate"):
        raise IdentValueError("initial_state", "'auto', 'rest' or 'estimate'", initial_state)
    if not fit_release and data.release_time_s is None and initial_state != "estimate":
        raise IdentValueError("release_time_s", "a known release with fit_release=False", None)
    y = np.asarray(data.y[:, output])
    moving = moving_outputs(data.y)
    if output not in moving and moving:   # a held cart's column: say which one moves
        raise IdentValueError(f"output {output}", f"a moving cart's column: fit_simple(data, ..., "
                              f"output={moving[0]}) or data.select_outputs({moving})", "no motion in it")
    check_motion(y)
    jumps = input_jumps(data.u)
    if jumps.size != 1:
        raise IdentValueError("u", "a single step (the release)", f"{jumps.size} changes")
    modes: tuple[Literal["rest", "estimate"], ...] = (
        (initial_state,) if initial_state != "auto"
        else ("rest", "estimate") if data.release_time_s is not None else ("rest",))
    outcomes: dict[str, _Outcome] = {}
    failure: FitFailed | None = None
    for mode in modes:
        try:   # the rest fit's friction is one more start of the estimate's (local minima)
            outcomes[mode] = _fit_from(data, y, method, friction, substeps, fit_release, mode, outcomes.get("rest"))
        except FitFailed as exc:
            failure = failure or exc
    if not outcomes:
        assert failure is not None
        raise failure
    chosen = _choose(outcomes, np.asarray(data.t) >= outcomes.get("estimate", outcomes[next(iter(outcomes))]).p[3])
    return _result(outcomes[chosen], data, y, method, substeps, friction, float(data.t[jumps[0] + 1]), chosen)


def _choose(outcomes: dict[str, _Outcome], after: NDArray[np.bool_]) -> Literal["rest", "estimate"]:
    """The release from rest, unless the estimated state lowers the cost over the samples from
    the stated release on (`after`: the estimate's, which leaves the hand's samples before it
    out) by more than noise explains (N ln(cost_rest / cost_estimate) > `CHOICE_CHI2`), or is
    the only fit left."""
    if "rest" not in outcomes:
        return "estimate"
    if "estimate" not in outcomes:
        return "rest"
    rest = float(np.sum(outcomes["rest"].fun[after] ** 2))
    estimate = float(np.sum(outcomes["estimate"].fun[after] ** 2))
    better = estimate > 0.0 and int(np.sum(after)) * float(np.log(rest / estimate)) > CHOICE_CHI2
    return "estimate" if better else "rest"


def _fit_from(data: IdData, y: FloatArray, method: Method, friction: bool, substeps: int, fit_release: bool,
              mode: Literal["rest", "estimate"], other: _Outcome | None = None) -> _Outcome:
    """One least-squares fit: the linear model, then (friction) the dry-friction model from it,
    and from `other`'s wn, ζ, f and rest level when given (another start's fit)."""
    amplitude = data.step_amplitude
    jumps = input_jumps(data.u)
    # unknown: start where u steps (whoever built `data` placed the step at the release)
    release0 = data.release_time_s if data.release_time_s is not None else float(data.t[int(jumps[0]) + 1])
    start = np.append(start_values(data.t, y, amplitude, release0), [0.0, 0.0])
    if mode == "estimate":
        final = start[4] + start[2] * amplitude
        start[4], start[6] = release_state(data.t, y, release0, start[0])
        start[2] = (final - start[4]) / amplitude
        bounds = (release0, release0)
    else:
        # a release the loader found is bounded near it; a step the caller placed in u may be a
        # guess (the motion's onset is then the start), bounded by the window only
        bounds = (release_bounds(data.t, release0, start[0]) if data.release_time_s is not None
                  else (float(data.t[0]), float(data.t[-1])))
        if not fit_release:
            bounds = (release0, release0)
        start[3] = float(np.clip(start[3], *bounds))
    free = np.array([True, True, True, bounds[0] < bounds[1], True, False, mode == "estimate"])
    # with friction the linear start is RK4's: Euler's inflated ζ would be a worse start
    linear_method: Method = "rk4" if friction else method
    if linear_method == "euler":
        start[1] = euler_zeta(start[0], start[1], sample_step(data.t) / substeps)
    _check_start(data.t, y, amplitude, linear_method, substeps, start)
    outcome = _least_squares(data.t, y, amplitude, linear_method, substeps, False, start, free, bounds)
    travel = float(np.sign(start[2])) or 1.0
    if friction:
        # a linear fit that ran off is refused before the friction fits start from it: their fine
        # grid grows with wn (a flick fitted from rest ran wn to 1.5e4 rad/s: 400 s)
        _check_outcome(outcome, bounds, linear_method, travel, sample_step(data.t))
        # the dry-friction fit starts from the linear fit with f = 0⁺, and from the linear fit
        # with ζ and f of the envelope regression |e_{j+1}| = ρ |e_j| - (1 + ρ) f / wn²; the
        # lower cost wins (the cost jumps with each stick: local minima)
        linear = outcome.p
        free[5] = True
        starts = [np.concatenate([linear[:5], [1e-3 * linear[0] ** 2 * abs(linear[2] * amplitude)], linear[6:]])]
        envelope = envelope_friction(data.t, y, release0, linear[0])
        if envelope is not None:
            # and the cart's measured state at the release: the linear fit's trades with the
            # decay it lacks (a velocity on a clean hold, and the level 13 % of the pull off)
            rest_level = linear[4] + linear[2] * amplitude
            starts.append(np.array([linear[0], envelope[0], (rest_level - start[4]) / amplitude, linear[3],
                                    start[4], envelope[1], start[6]]))
        if other is not None:
            rest_level = other.p[4] + other.p[2] * amplitude
            starts.append(np.array([other.p[0], other.p[1], (rest_level - linear[4]) / amplitude, linear[3],
                                    linear[4], other.p[5], linear[6]]))
        outcomes = [_least_squares(data.t, y, amplitude, method, substeps, True, p0, free, bounds) for p0 in starts]
        outcome = min(outcomes, key=lambda o: o.cost)
    _check_outcome(outcome, bounds, method, travel, sample_step(data.t))
    return outcome


def release_bounds(t: FloatArray, release0: float, wn: float) -> tuple[float, float]:
    """Where the data can place the release (s): within `RELEASE_PERIODS` of a start-value
    period 2π/wn around `release0`, and not before the first sample.

    Before the first sample no datum shows the rest the model starts from, so a release there
    trades against the gain and the offset freely: unbounded, a window that starts just after a
    flicked cart's release ran its release 0.15 s before the data with a gain of -4, and an
    Euler fit to -8259 s.
    """
    half = RELEASE_PERIODS * 2.0 * np.pi / wn if np.isfinite(wn) and wn > 0.0 else 0.0
    low = release0 - half
    high = min(float(t[-1]), max(release0 + half, low))
    return low, max(high, np.nextafter(low, np.inf))


def _check_outcome(outcome: _Outcome, bounds: tuple[float, float], method: Method, travel: float,
                   h: float) -> None:
    """Refuse a fit that ran off: non-finite parameters, wn ≤ 0 or above the samples' Nyquist
    frequency π/h (an alias: a 123 Hz flick fitted from rest with friction ran to wn 390.6
    rad/s, truth 22.9, and the friction fit started from it took 16 s), a release outside `bounds`
    or a gain whose sign is not `travel`'s, the sign of the data's own travel over the pull
    (final level less the level at the release, over U): a released cart moves toward the
    spring's rest, so g U has that sign (g < 0 is right when U was given with the other sign
    than the pull's; a gain of the wrong sign is a fit that ran off)."""
    wn, _zeta, gain, release = (float(v) for v in outcome.p[:4])
    low, high = bounds
    problems = []
    if not np.all(np.isfinite(outcome.p)):
        problems.append(f"parameters {np.round(outcome.p, 6).tolist()}, expected finite values")
    if not wn > 0.0:
        problems.append(f"wn {wn:.4g} rad/s, expected > 0")
    elif h > 0.0 and not wn * h < np.pi:
        problems.append(f"wn {wn:.4g} rad/s, expected below the samples' Nyquist frequency {np.pi / h:.4g} rad/s")
    margin = 1e-3 * (high - low)   # trf stops short of a bound the optimum lies beyond
    if not low + margin < release < high - margin and low < high:
        problems.append(f"release {release:.4f} s, expected inside [{low:.4f}, {high:.4f}] s "
                        "(where the data can place it: a quarter period around a found release, "
                        "else the window)")
    if not gain * travel > 0.0:
        problems.append(f"gain {gain:.4g}, expected {'> 0' if travel > 0 else '< 0'} (the cart released toward "
                        "its rest: the sign of the data's travel over the pull)")
    if problems:
        raise FitFailed(f"the {method} simple fit ran off ({outcome.message}): " + "; ".join(problems)
                        + ": check that the window holds the release and the ring after it, and that u "
                          "steps at the release by the pull; or fit with fit_release=False")


def _check_start(t: FloatArray, y: FloatArray, amplitude: float, method: Method, substeps: int,
                 start: FloatArray) -> None:
    """Refuse, with what to do, a start whose simulation is not finite (the optimiser would
    only say "Residuals are not finite in the initial point")."""
    with np.errstate(over="ignore", invalid="ignore"):   # an overflow is what is checked here
        finite = bool(np.all(np.isfinite(start))) and bool(np.all(np.isfinite(
            _response(start, t, amplitude, method, substeps, False))))
    if finite:
        return
    wn_h = float(start[0]) * sample_step(t) / substeps
    raise FitFailed(f"the start values (wn {start[0]:.4g} rad/s, zeta {start[1]:.3g}) give a non-finite "
                    f"{method} simulation at wn·h = {wn_h:.3g} per step: expected a start from a ring "
                    "sampled well above its frequency; check the record's rate and motion, or fit with "
                    "method='rk4' or more substeps")


@dataclass(frozen=True)
class _Outcome:
    """A least-squares run: all parameters `p` (release included), the Jacobian and the
    names of the free ones."""

    p: FloatArray
    jac: FloatArray
    fun: FloatArray
    names: tuple[str, ...]
    cost: float
    nfev: int
    success: bool
    message: str


def _least_squares(t: FloatArray, y: FloatArray, amplitude: float, method: Method, substeps: int,
                   friction: bool, start: FloatArray, free: NDArray[np.bool_],
                   release_range: tuple[float, float]) -> _Outcome:
    """Trust-region least squares over the `free` parameters of p = (wn, ζ, g, t_r, o, f, v0),
    the others held at `start`; bounded in the release time only (`release_range`, s): bounds
    on the other parameters stalled the friction fit in local minima."""
    from scipy.optimize import least_squares  # deferred: keeps `import ident` fast
    free = free.copy()

    def full(q: FloatArray) -> FloatArray:
        p = start.copy()
        p[free] = q
        return p

    # with the state at the release estimated, the samples before it are the hand's: no model
    counted = t >= release_range[0] if free[6] else np.ones(t.size, dtype=bool)

    def residual(q: FloatArray) -> FloatArray:
        return np.asarray(np.where(counted, _response(full(q), t, amplitude, method, substeps, friction) - y, 0.0))

    # stick events make the friction model's output jump with its parameters: difference
    # over a wider step (10⁻³ relative) so the Jacobian sees the trend, not the jumps
    low = np.full(start.size, -np.inf)
    high = np.full(start.size, np.inf)
    low[3], high[3] = release_range
    result = least_squares(residual, start[free], bounds=(low[free], high[free]), method="trf", x_scale="jac",
                           diff_step=1e-3 if friction else 1e-7, xtol=1e-12, ftol=1e-12, max_nfev=400)
    names = tuple(n for n, keep in zip(PARAMETER_NAMES, free, strict=True) if keep)
    return _Outcome(full(result.x), np.asarray(result.jac), np.asarray(result.fun), names,
                    float(result.cost), int(result.nfev), bool(result.success), str(result.message))


def _result(outcome: _Outcome, data: IdData, y: FloatArray, method: Method, substeps: int,
            friction: bool, step_time: float, mode: Literal["rest", "estimate"]) -> SimpleFit:
    p, jac, residuals = outcome.p, outcome.jac, outcome.fun
    s2 = float(residuals @ residuals) / max(1, residuals.size - jac.shape[1])
    covariance = s2 * np.linalg.pinv(jac.T @ jac)
    std = {name: float(np.sqrt(max(covariance[i, i], 0.0))) for i, name in enumerate(outcome.names)}
    y_hat = _response(p, np.asarray(data.t), data.step_amplitude, method, substeps, friction)
    counted = np.asarray(data.t) >= p[3] if mode == "estimate" else np.ones(y.size, dtype=bool)
    display = None
    if friction:
        display = (p[4] + euler_coulomb(p[0], p[1], p[5], p[2] * data.step_amplitude, np.asarray(data.t),
                                        p[3], substeps, p[6]))[:, None]
    return SimpleFit(wn=float(p[0]), zeta=float(p[1]), gain=float(p[2]), release_time_s=float(p[3]),
                     offset=float(p[4]), friction=abs(float(p[5])) if friction else None, method=method,
                     substeps=substeps, names=outcome.names, covariance=covariance, std_errors=std,
                     fit_percent=tuple(fit_percent(y[counted], y_hat[counted])), residuals=(y - y_hat)[:, None],
                     input_delay_s=float(p[3]) - step_time, t=np.asarray(data.t),
                     y_hat=y_hat[:, None], nfev=outcome.nfev, success=outcome.success,
                     message=outcome.message, euler_display=display, release_velocity=float(p[6]),
                     initial_state=mode)
