"""Simple identification (the lab's Part 2): fit the physical single-cart model by simulation.

Model, in the zeroed frame, released from rest at t_r with pull U (m):

    x'' + 2ζ wn x' + wn² (x - g U H(t - t_r)) [+ f sign(x')] = 0,   y = o + x + e,

simulated on the sample grid by RK4 or explicit Euler (`ident.physics.steppers`), parameters
p = (wn, ζ, g, t_r, o[, f]) fitted by minimising the output error Σ (y - ŷ(p))² with
`scipy.optimize.least_squares` (finite-difference Jacobian on scaled parameters). Start
values come from the data: t_r from the onset of the motion, g from the final level, the
damped period from the zero crossings of y - y_final and σ = ζ wn from the logarithmic
decrement of the successive extrema. The release time stays a continuous parameter: the
simulation takes one partial step from t_r to the first sample after it.

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

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ident import summary
from ident.comparison import fit_percent
from ident.data import IdData
from ident.errors import FitFailed, IdentValueError
from ident.physics.free import NonlinearTerms, simulate_free
from ident.physics.measures import encoder_quantum
from ident.physics.steppers import Method, euler_coulomb, linear_step_response
from ident.release import check_motion, moving_outputs, noise_std, rest_window

FloatArray = NDArray[np.float64]
PARAMETER_NAMES = ("wn", "zeta", "gain", "release_time_s", "offset", "friction")
#: h·wn of the fine grid the dry-friction model is simulated on (converged: see the docstring).
FINE_H_WN = 0.01
#: A swing about the final level counts as motion above this many noise std ...
SWING_NOISE = 10.0
#: ... and this many encoder quanta (a stuck cart dithers by one count).
SWING_QUANTA = 3.0


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

    def summary_rows(self) -> list[tuple[str, str]]:
        """The labelled lines of `repr` and `_repr_html_` (arrays stay in the attributes)."""
        def value(name: str, unit: str = "") -> str:
            return summary.with_std(getattr(self, name), self.std_errors.get(name, float("nan")), unit=unit)

        rows = [("wn", value("wn", "rad/s")), ("zeta", value("zeta")), ("gain", value("gain"))]
        if self.friction is not None:
            rows.append(("friction", value("friction", "m/s²")))
        rows += [("release", f"{self.release_time_s:.4f} s"),
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
        params = np.array([self.wn, self.zeta, self.gain, release, self.offset, self.friction or 0.0])
        y = _response(params, t_arr, float(u_arr[-1] - u_arr[0]), self.method, self.substeps,
                      self.friction is not None)
        return y[:, None]


def _response(p: FloatArray, t: FloatArray, amplitude: float, method: Method, substeps: int,
              with_friction: bool) -> FloatArray:
    wn, zeta, gain, t_r, offset = p[:5]
    if with_friction:
        if method != "euler":
            raise IdentValueError("method", "'euler' for the dry-friction model", method)
        return offset + coulomb_response(wn, zeta, p[5], gain * amplitude, t, t_r)
    A = np.array([[0.0, 1.0], [-wn * wn, -2.0 * zeta * wn]])
    B = np.array([[0.0], [wn * wn]])
    return offset + linear_step_response(A, B, t, t_r, gain * amplitude, method, substeps)[:, 0]


def coulomb_response(wn: float, zeta: float, friction: float, r: float, t: FloatArray,
                     release_time_s: float) -> FloatArray:
    """Positions (N,) of x'' + 2ζwn x' + wn² (x - r) + f sign(x') = 0 (static = kinetic f, m/s²),
    at rest at 0 until t_r: the physics' free response on a uniform grid from t_r with
    h·wn ≤ FINE_H_WN, linearly interpolated at the samples (error ≈ (h wn)² r / 8)."""
    t = np.asarray(t, dtype=np.float64)
    out = np.zeros(t.size)
    after = t > release_time_s
    if not np.any(after) or not (np.isfinite(wn) and wn > 0.0):
        return out
    tau = t[after] - release_time_s
    n = int(np.ceil(tau[-1] * wn / FINE_H_WN)) + 2
    h = tau[-1] / (n - 1)
    terms = NonlinearTerms(friction_m_s2=np.array([[abs(friction)]]))
    deviation = simulate_free(np.array([[wn, zeta]]), np.array([[-r, 0.0]]), h, n, 1, terms)[0, :, 0]
    out[after] = r + np.interp(tau, h * np.arange(n), deviation)
    return out


def start_values(t: FloatArray, y: FloatArray, amplitude: float, release0: float) -> FloatArray:
    """(wn, ζ, g, t_r, o) from the data: period from zero crossings, σ from the log decrement.

    A crossing counts only while the swings are larger than the noise and than the encoder's
    quantum (`swing_floor`): a cart stuck between two counts dithers across the final level
    every sample, and those crossings would set the period to two samples.
    """
    offset = float(np.median(y[rest_window(len(y))]))
    after = t > release0
    tail = y[after][-max(5, int(after.sum()) // 10):]
    final = float(np.mean(tail))
    gain = (final - offset) / amplitude
    e = y[after] - final
    ta = t[after]
    crossings = _significant_crossings(e, swing_floor(y))
    if crossings.size < 3:
        raise FitFailed(f"expected an oscillation (≥ 3 crossings of the final level), got {crossings.size}")
    t_cross = ta[crossings] - e[crossings] * (ta[crossings + 1] - ta[crossings]) / (e[crossings + 1] - e[crossings])
    omega_d = np.pi / float(np.median(np.diff(t_cross)))
    peaks = np.array([np.max(np.abs(e[a:b + 1])) for a, b in itertools.pairwise(crossings)])
    times = np.array([ta[a + int(np.argmax(np.abs(e[a:b + 1])))] for a, b in itertools.pairwise(crossings)])
    usable = peaks > 0.05 * peaks[0]
    sigma = 0.05 * omega_d
    if usable.sum() >= 2:
        slope = np.polyfit(times[usable], np.log(peaks[usable]), 1)[0]
        sigma = max(-float(slope), 1e-3 * omega_d)
    wn = float(np.hypot(omega_d, sigma))
    return np.array([wn, sigma / wn, gain, release0, offset])


def swing_floor(y: FloatArray) -> float:
    """Smallest swing (m) about the final level that is motion, not noise: the larger of
    `SWING_NOISE` noise std and `SWING_QUANTA` encoder quanta.

    The quantum is the smallest non-zero step between samples. On a quantized record the rest
    reads one count, so its noise std is ~0 and the quantum is what bounds the dither.
    """
    return max(SWING_NOISE * float(noise_std(y)[0]), SWING_QUANTA * encoder_quantum(y))


def _significant_crossings(e: FloatArray, floor: float) -> NDArray[np.int64]:
    """Indices k where e changes sign between k and k+1, kept while the swing between
    crossings exceeds `floor` (noise or a count's dither around a stuck cart makes spurious
    crossings)."""
    signs = np.signbit(e)
    crossings = np.flatnonzero(signs[1:] != signs[:-1])
    kept = [int(crossings[0])] if crossings.size else []
    for a, b in itertools.pairwise(crossings):
        if np.max(np.abs(e[a:b + 1])) < floor:
            break
        kept.append(int(b))
    return np.array(kept, dtype=np.int64)


def fit_simple(data: IdData, method: Method = "rk4", *, friction: bool = False, substeps: int = 1,
               output: int = 0, fit_release: bool = True) -> SimpleFit:
    """Fit wn, ζ, gain, release time, offset (and dry friction f, Euler only) of one cart.

    `output` picks the column of `data.y`; `data.u` gives the pull amplitude U.
    `fit_release=False` holds the release at `data.release_time_s` (required then).
    """
    if method not in ("rk4", "euler"):
        raise IdentValueError("method", "'rk4' or 'euler'", method)
    if friction and method != "euler":
        raise IdentValueError("method", "'euler' when friction=True (the Coulomb model)", method)
    if not fit_release and data.release_time_s is None:
        raise IdentValueError("release_time_s", "a known release with fit_release=False", None)
    y = np.asarray(data.y[:, output])
    moving = moving_outputs(data.y)
    if output not in moving and moving:   # a held cart's column: say which one moves
        raise IdentValueError(f"output {output}", f"a moving cart's column: fit_simple(data, ..., "
                              f"output={moving[0]}) or data.select_outputs({moving})", "no motion in it")
    check_motion(y)
    amplitude = data.step_amplitude
    jumps = np.flatnonzero(np.diff(data.u) != 0.0)
    if jumps.size != 1:
        raise IdentValueError("u", "a single step (the release)", f"{jumps.size} changes")
    # unknown: start where u steps (whoever built `data` placed the step at the release)
    release0 = data.release_time_s if data.release_time_s is not None else float(data.t[int(jumps[0]) + 1])
    fixed = None if fit_release else release0
    start = start_values(data.t, y, amplitude, release0)
    # with friction the linear start is RK4's: Euler's inflated ζ would be a worse start
    linear_method: Method = "rk4" if friction else method
    if linear_method == "euler":
        start[1] = euler_zeta(start[0], start[1], _sample_step(data.t) / substeps)
    _check_start(data.t, y, amplitude, linear_method, substeps, start)
    outcome = _least_squares(data.t, y, amplitude, linear_method, substeps, False, start, fixed)
    if friction:
        # the dry-friction fit starts from the linear fit, with f = 0⁺ and with f from the
        # envelope regression |e_{j+1}| = ρ |e_j| - 2 f / wn²; the lower cost wins
        linear = outcome.p
        tries = [np.append(linear, 1e-3 * linear[0] ** 2 * abs(linear[2] * amplitude)),
                 np.append(linear, envelope_friction(data.t, y, release0, linear[0]))]
        outcomes = [_least_squares(data.t, y, amplitude, method, substeps, True, p0, fixed) for p0 in tries]
        outcome = min(outcomes, key=lambda o: o.cost)
    return _result(outcome, data, y, method, substeps, friction, float(data.t[jumps[0] + 1]))


def euler_zeta(wn: float, zeta: float, h: float) -> float:
    """The ζ with which explicit Euler at step h (s) decays like the true ring: the start of
    an Euler fit, whose answer is biased that way (the module docstring).

    Euler's pole 1 + hλ has |1 + hλ|² = 1 - 2ζ_E wn h + (wn h)²; the ring decays by
    e^{-2ζ wn h} per step in energy, so ζ_E = (1 + (wn h)² - e^{-2ζ wn h}) / (2 wn h)
    (≈ ζ + wn h/2 for small wn h). Starting from the physical ζ instead, Euler's amplitude
    grows by √(1 + (wn h)²) per step, past any float on a long record at a coarse rate.
    """
    x = wn * h
    if not x > 0.0:
        return zeta
    return float((1.0 + x * x - np.exp(-2.0 * zeta * x)) / (2.0 * x))


def _sample_step(t: FloatArray) -> float:
    """The median sample step (s) of the time base."""
    return float(np.median(np.diff(t))) if t.size > 1 else 0.0


def _check_start(t: FloatArray, y: FloatArray, amplitude: float, method: Method, substeps: int,
                 start: FloatArray) -> None:
    """Refuse, with what to do, a start whose simulation is not finite (the optimiser would
    only say "Residuals are not finite in the initial point")."""
    with np.errstate(over="ignore", invalid="ignore"):   # an overflow is what is checked here
        finite = bool(np.all(np.isfinite(start))) and bool(np.all(np.isfinite(
            _response(start, t, amplitude, method, substeps, False))))
    if finite:
        return
    wn_h = float(start[0]) * _sample_step(t) / substeps
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
                   friction: bool, start: FloatArray, fixed_release: float | None) -> _Outcome:
    """Unbounded trust-region least squares (bounds stalled the friction fit in local minima)."""
    from scipy.optimize import least_squares  # deferred: keeps `import ident` fast
    free = np.ones(start.size, dtype=bool)
    if fixed_release is not None:
        free[3] = False
        start = start.copy()
        start[3] = fixed_release

    def full(q: FloatArray) -> FloatArray:
        p = start.copy()
        p[free] = q
        return p

    def residual(q: FloatArray) -> FloatArray:
        return np.asarray(_response(full(q), t, amplitude, method, substeps, friction) - y)

    # stick events make the friction model's output jump with its parameters: difference
    # over a wider step (10⁻³ relative) so the Jacobian sees the trend, not the jumps
    result = least_squares(residual, start[free], method="trf", x_scale="jac",
                           diff_step=1e-3 if friction else 1e-7, xtol=1e-12, ftol=1e-12, max_nfev=400)
    names = tuple(n for n, keep in zip(PARAMETER_NAMES[:start.size], free, strict=True) if keep)
    return _Outcome(full(result.x), np.asarray(result.jac), np.asarray(result.fun), names,
                    float(result.cost), int(result.nfev), bool(result.success), str(result.message))


def envelope_friction(t: FloatArray, y: FloatArray, release0: float, wn: float) -> float:
    """Dry-friction start value f (m/s²) from successive extrema |e_j| of y - y_final:
    with Coulomb friction |e_{j+1}| = ρ |e_j| - 2 f / wn², a straight line in |e_j|."""
    after = t > release0
    e = y[after] - float(np.mean(y[after][-max(5, int(after.sum()) // 10):]))
    crossings = _significant_crossings(e, swing_floor(y))
    peaks = np.array([np.max(np.abs(e[a:b + 1])) for a, b in itertools.pairwise(crossings)])
    if peaks.size < 3:
        return 0.0
    _slope, intercept = np.polyfit(peaks[:-1], peaks[1:], 1)
    return float(max(-intercept * wn * wn / 2.0, 0.0))


def _result(outcome: _Outcome, data: IdData, y: FloatArray, method: Method, substeps: int,
            friction: bool, step_time: float) -> SimpleFit:
    p, jac, residuals = outcome.p, outcome.jac, outcome.fun
    s2 = float(residuals @ residuals) / max(1, residuals.size - jac.shape[1])
    covariance = s2 * np.linalg.pinv(jac.T @ jac)
    std = {name: float(np.sqrt(max(covariance[i, i], 0.0))) for i, name in enumerate(outcome.names)}
    y_hat = y + residuals
    display = None
    if friction:
        display = (p[4] + euler_coulomb(p[0], p[1], p[5], p[2] * data.step_amplitude, np.asarray(data.t),
                                        p[3], substeps))[:, None]
    return SimpleFit(wn=float(p[0]), zeta=float(p[1]), gain=float(p[2]), release_time_s=float(p[3]),
                     offset=float(p[4]), friction=abs(float(p[5])) if friction else None, method=method,
                     substeps=substeps, names=outcome.names, covariance=covariance, std_errors=std,
                     fit_percent=tuple(fit_percent(y, y_hat)), residuals=-residuals[:, None],
                     input_delay_s=float(p[3]) - step_time, t=np.asarray(data.t),
                     y_hat=y_hat[:, None], nfev=outcome.nfev, success=outcome.success,
                     message=outcome.message, euler_display=display)
