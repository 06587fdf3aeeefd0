"""The identified linear model: continuous-time modal state space plus the run's facts.

`Model.simulate(u)` gives the free-run (output-error) simulation on the data's time base:
the input is held between samples and delayed by `input_delay_s`, which is where the
continuously estimated release time lives (the step in the sampled `u` is at a sample; the
release is between samples). For a single-step `u` the response is evaluated in closed form
(exact on any time base); otherwise by exact zero-order-hold discretisation with the
fractional delay split over the sample interval, on a uniform time base.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ident import modal, predictor, summary
from ident.data import input_jumps
from ident.errors import IdentDimensionError, IdentValueError
from ident.physics import Mode, StateSpace, transfer_functions

if TYPE_CHECKING:
    import control

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ModeEstimate:
    """A mode with its standard errors (NaN when not available)."""

    wn: float
    zeta: float
    wn_std: float = float("nan")
    zeta_std: float = float("nan")

    @property
    def mode(self) -> Mode:
        return Mode(self.wn, self.zeta)


@dataclass(frozen=True)
class Model:
    """A fitted model `y = offset + G(s) u(t - input_delay_s) + e`, from rest at u = 0.

    `sigma`, `omega` (m,): poles -σ ± jω; `theta` (n_out, 1 + 2m): (D, c0_i, c1_i) of
    `ident.modal`; `t` (N,) the time base; `relative_degree` per output as fitted; `K`
    (n, n_out) the innovation gain at the time base's Ts (None: output-error noise model);
    `initial_velocity` (n_out, m) m/s: with the initial state estimated (a flicked cart let go
    moving at `release_time_s`), each mode's velocity there, whose free response
    Σ_i v_ji e^{-σ_i τ} sin(ω_i τ)/ω_i is added to the step's (None: released from rest).
    """

    sigma: FloatArray
    omega: FloatArray
    theta: FloatArray
    offset: FloatArray
    t: FloatArray
    input_delay_s: float
    release_time_s: float | None
    relative_degree: tuple[int, ...]
    modes: tuple[ModeEstimate, ...]
    fit_percent: tuple[float, ...]
    noise_std: FloatArray
    residuals: FloatArray
    covariance: FloatArray
    method: str
    nfev: int
    success: bool
    message: str
    notes: tuple[str, ...] = field(default=())
    K: FloatArray | None = None
    initial_velocity: FloatArray | None = None

    @property
    def order(self) -> int:
        return 2 * len(self.sigma)

    @property
    def unstable_modes(self) -> tuple[int, ...]:
        """Indices into `modes` of the modes with ζ ≤ 0: poles -σ ± jω with σ ≤ 0, on or right of
        the imaginary axis (|z| = e^{-σ Ts} ≥ 1 once sampled). No spring cart does that."""
        return tuple(i for i, mode in enumerate(self.modes) if not mode.zeta > 0.0)

    @property
    def stable(self) -> bool:
        """Every pole strictly in the left half-plane (ζ > 0 in every mode)."""
        return not self.unstable_modes

    @property
    def n_outputs(self) -> int:
        return int(self.theta.shape[0])

    @property
    def state_space(self) -> StateSpace:
        A, B, C, D = modal.state_space(self.sigma, self.omega, self.theta)
        return StateSpace(A, B, C, D)

    @property
    def poles(self) -> NDArray[np.complex128]:
        upper = self.omega * 1j - self.sigma
        return np.concatenate([upper, np.conj(upper)])

    @property
    def dc_gain(self) -> FloatArray:
        """G_j(0) = D_j + Σ c0_ij / wn_i², shape (n_out,)."""
        wn2 = self.sigma ** 2 + self.omega ** 2
        return np.asarray(self.theta[:, 0] + self.theta[:, 1::2] @ (1.0 / wn2))

    def tf_coefficients(self) -> list[tuple[FloatArray, FloatArray]]:
        """[(num, den)] per output, continuous time, highest power first."""
        return [modal.tf_coefficients(self.sigma, self.omega, self.theta[j], self.relative_degree[j])
                for j in range(self.n_outputs)]

    @property
    def tf(self) -> list[control.TransferFunction]:
        """Continuous-time `control.TransferFunction`, one per output (control imported lazily)."""
        return transfer_functions(self.tf_coefficients())

    def discrete(self, ts: float | None = None) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Innovation form (Ad, Bd, C, D, K) at sample time `ts` (default: the time base's), zoh.

        K is the estimated innovation gain (`pem(..., noise_model="innovation")`), zero for
        the output-error noise model (H = 1). K belongs to the fitted sample time only.
        """
        from scipy.linalg import expm  # deferred: keeps `import ident` fast
        step = float(np.median(np.diff(self.t))) if ts is None else ts
        ss = self.state_space
        n = ss.A.shape[0]
        aug = np.zeros((n + 1, n + 1))
        aug[:n, :n] = ss.A * step
        aug[:n, n:] = ss.B * step
        e = expm(aug)
        gain = np.zeros((n, self.n_outputs)) if self.K is None else self.K
        return e[:n, :n], e[:n, n:], ss.C, ss.D, gain

    def predict(self, u: ArrayLike, y: ArrayLike) -> FloatArray:
        """One-step-ahead predictions (N, n_out) on the fitted time base (uniform)."""
        gain = np.zeros((self.order, self.n_outputs)) if self.K is None else self.K
        ts = float(np.median(np.diff(self.t)))
        return predictor.predict(self.sigma, self.omega, self.theta, self.offset, gain,
                       np.asarray(u, dtype=np.float64).reshape(-1),
                       np.asarray(y, dtype=np.float64).reshape(len(self.t), -1), ts, self.input_delay_s)

    def simulate(self, u: ArrayLike, t: ArrayLike | None = None) -> FloatArray:
        """Free-run simulated output (N, n_out) for input `u` (N,) on time base `t` (default:
        the fitted data's), starting at rest at u = 0 (an input already on at the first
        sample is switched on there: `ident.data.input_jumps`)."""
        t_arr = self.t if t is None else np.asarray(t, dtype=np.float64)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        if u_arr.shape != t_arr.shape:
            raise IdentDimensionError("u", f"shape {t_arr.shape} (one value per time stamp)",
                                      f"shape {np.asarray(u).shape}")
        jumps = input_jumps(u_arr)
        if jumps.size == 0:
            return np.tile(self.offset, (len(t_arr), 1))
        if jumps.size == 1:
            release = float(t_arr[jumps[0] + 1]) + self.input_delay_s
            basis = modal.step_basis(t_arr, release, self.sigma, self.omega)
            y = self.offset + u_arr[-1] * basis @ self.theta.T
            if self.initial_velocity is not None:   # the flick's own motion from the release
                y = y + basis[:, 2::2] @ self.initial_velocity.T
            return np.asarray(y)
        return self._simulate_zoh(u_arr, t_arr)

    def summary_rows(self) -> list[tuple[str, str]]:
        """The labelled lines of `repr` and `_repr_html_` (all arrays stay in the attributes)."""
        rows = [(f"mode {i + 1}", (f"wn = {summary.with_std(m.wn, m.wn_std, unit='rad/s')}, "
                                   f"zeta = {summary.with_std(m.zeta, m.zeta_std)}"))
                for i, m in enumerate(self.modes)]
        rows.append(("fit (simulation)", summary.percents(self.fit_percent)))
        rows.append(("noise std", ", ".join(f"{v:.3g} m" for v in np.atleast_1d(self.noise_std))))
        rows.append(("dc gain", ", ".join(f"{v:.4g}" for v in self.dc_gain)))
        release = "n/a" if self.release_time_s is None else f"{self.release_time_s:.4f} s"
        rows.append(("release", f"{release} (input delay {1e3 * self.input_delay_s:.3g} ms)"))
        if self.initial_velocity is not None:
            rows.append(("initial state", "estimated: velocity at the release "
                         + ", ".join(f"{v:.4g} m/s" for v in self.initial_velocity.sum(axis=1))))
        rows.append(("data", f"{len(self.t)} samples, Ts = {float(np.median(np.diff(self.t))):.4g} s"))
        state = "converged" if self.success else "NOT converged"
        rows.append(("status", f"{state}, {self.nfev} evaluations: {self.message}"))
        rows.extend(("note", note) for note in self.notes)
        rows.append(("see", ("model.tf (control.TransferFunction per output), model.state_space, "
                             "model.poles, ident.compare(data, model)")))
        return rows

    def _title(self) -> str:
        noise = "output error" if self.K is None else "innovation form"
        return (f"Continuous-time model, order {self.order}, {self.n_outputs} output(s), "
                f"{self.method} ({noise})")

    def __repr__(self) -> str:
        return summary.text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary.html_table(self._title(), self.summary_rows())

    def _simulate_zoh(self, u: FloatArray, t: FloatArray) -> FloatArray:
        steps = np.diff(t)
        ts = float(np.median(steps))
        if np.max(np.abs(steps - ts)) > 0.25 * ts:
            raise IdentValueError("time base", "uniform sampling to simulate a general input",
                                  f"steps from {steps.min():.4g} to {steps.max():.4g} s")
        delay_samples = self.input_delay_s / ts
        whole = int(np.floor(delay_samples))
        frac = delay_samples - whole
        shifted = predictor.shift(u, whole)
        columns = [predictor.shift(shifted, 1) if frac > 0 else shifted]
        for s, w in zip(self.sigma, self.omega, strict=True):
            columns.extend(modal.section_states(float(s), float(w), ts, frac, shifted))
        return np.asarray(self.offset + np.column_stack(columns) @ self.theta.T)
