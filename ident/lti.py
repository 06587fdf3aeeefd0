"""python-control LTI objects as `ident` models, and `d2c` for python-control systems.

A hand-derived `control.tf`/`control.ss` (continuous or discrete) becomes something with
`simulate(u, t) -> y_hat (N, n_out)` so `compare`, `resid` and `simulate` take it like a fitted
`Model`. Simulation is exact for an input held between samples (the `ident` convention):

    continuous (A, B, C, D):  x[k+1] = Φ x[k] + Γ u[k],  [[Φ, Γ], [0, I]] = expm([[A, B], [0, 0]] Ts),
    discrete at Ts:           Φ, Γ = A, B  (the model's own sample time must match the data's),
    y[k] = C x[k] + D u[k],   from rest at u = 0: x[0] = 0 (an input already on at the first
                              sample was switched on there, `ident.data.input_jumps`).

A list of SISO systems (e.g. `Model.tf`) is one model per output column. `control` is imported
only by the functions that need it (it costs about a second). No files, no clocks.

`d2c(sys, method)` inverts python-control's `sample_system` (which has no inverse):
- `zoh`: A, B from the matrix logarithm (`ident.d2c.d2c_zoh`), C and D unchanged;
- `tustin`: with α = Ts/2 and M = (Φ + I)/2 = (I - αA)⁻¹,
  A = (I - M⁻¹)/α, B = M⁻¹ Γ / Ts, C = C_d M⁻¹, D = D_d - C_d M⁻¹ Γ / 2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ident.errors import IdentDimensionError, IdentValueError
from ident.zoh import c2d_zoh, d2c_zoh

if TYPE_CHECKING:
    import control

FloatArray = NDArray[np.float64]
#: Sample times of the model and of the data agree within this fraction.
TS_TOLERANCE = 0.01


def is_lti(obj: object) -> bool:
    """True for a python-control LTI system or a non-empty list of them (without importing control
    when it is not loaded: then nothing can be one)."""
    import sys

    control = sys.modules.get("control")
    if control is None:
        return False
    if isinstance(obj, control.LTI):
        return True
    return isinstance(obj, list | tuple) and len(obj) > 0 and all(isinstance(s, control.LTI) for s in obj)


@dataclass(frozen=True)
class LtiSimulator:
    """A python-control system (or one SISO system per output) as an `ident` simulator."""

    systems: tuple[Any, ...]

    @property
    def n_outputs(self) -> int:
        return sum(int(s.noutputs) for s in self.systems)

    def simulate(self, u: ArrayLike, t: ArrayLike | None = None) -> FloatArray:
        """Output (N, n_outputs) for the input `u` (N,) held between the uniform stamps `t` (N,)."""
        if t is None:
            raise IdentValueError("t", "the data's time base (a python-control system has none)", None)
        t_arr = np.asarray(t, dtype=np.float64).reshape(-1)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        if u_arr.shape != t_arr.shape:
            raise IdentDimensionError("u", f"shape {t_arr.shape} (one value per time stamp)", f"shape {u_arr.shape}")
        ts = _uniform_step(t_arr)
        return np.column_stack([_simulate_one(s, u_arr, ts) for s in self.systems])


def as_simulator(obj: object) -> LtiSimulator:
    """Wrap a python-control system or a list of them (one per output)."""
    systems = tuple(obj) if isinstance(obj, list | tuple) else (obj,)
    for s in systems:
        if int(s.ninputs) != 1:
            raise IdentDimensionError("model", "one input (the pull r(t))", f"{s.ninputs} inputs")
    return LtiSimulator(systems)


def _uniform_step(t: FloatArray) -> float:
    steps = np.diff(t)
    ts = float(np.median(steps))
    if np.max(np.abs(steps - ts)) > 0.25 * ts:
        raise IdentValueError("time base", "uniform sampling to simulate a python-control system "
                              "(resample with ident.make_uniform(data))",
                              f"steps from {steps.min():.4g} to {steps.max():.4g} s")
    return ts


def _discrete_matrices(system: Any, ts: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    import control

    ss = control.ss(system)
    A, B, C, D = (np.asarray(m, dtype=np.float64) for m in (ss.A, ss.B, ss.C, ss.D))
    dt = system.dt
    if dt is None or dt == 0 or dt is False:       # continuous (None: either; taken as continuous)
        phi, gamma = c2d_zoh(A, B, ts) if A.size else (A, B)
        return phi, gamma, C, D
    if dt is not True and abs(float(dt) - ts) > TS_TOLERANCE * ts:
        raise IdentValueError("model sample time", f"the data's Ts = {ts:.6g} s (convert with "
                              "ident.d2c(sys) or resample the data)", f"dt = {float(dt):.6g} s")
    return A, B, C, D


def _simulate_one(system: Any, u: FloatArray, ts: float) -> FloatArray:
    """y (N, n_out) of one system from rest at u = 0, input held over each sample (one
    already on at the first sample was switched on there: `ident.data.input_jumps`)."""
    phi, gamma, C, D = _discrete_matrices(system, ts)
    n = phi.shape[0]
    if n == 0:
        return np.outer(u, D[:, 0]).astype(np.float64, copy=False)
    x = np.zeros(n)
    states = np.empty((u.size, n))
    g = gamma[:, 0]
    for k in range(u.size):   # N ≤ a few 10⁴ samples of a 2–8 state model: the loop is cheap
        states[k] = x
        x = phi @ x + g * u[k]
    return np.asarray(states @ C.T + np.outer(u, D[:, 0]))


def d2c(sys: control.LTI, method: Literal["zoh", "tustin"] = "zoh") -> control.LTI:
    """The continuous-time system whose `method`-discretisation at `sys.dt` is `sys`.

    Returns the same kind of object as given (TransferFunction in, TransferFunction out).
    Raises `IdentValueError` for a continuous system, an unknown sample time, an unknown
    method, or (zoh) a pole on the negative real axis, which no continuous system samples to.
    """
    import control

    if not isinstance(sys, control.LTI):
        raise IdentValueError("sys", "a python-control TransferFunction or StateSpace", type(sys).__name__)
    dt = sys.dt
    if dt is None or dt is True or dt is False or not float(dt) > 0:
        raise IdentValueError("sys.dt", "a discrete-time system with a sample time (dt > 0 s)", dt)
    ts = float(dt)
    ss = control.ss(sys)
    phi, gamma, c_d, d_d = (np.asarray(m, dtype=np.float64) for m in (ss.A, ss.B, ss.C, ss.D))
    if method == "zoh":
        A, B = d2c_zoh(phi, gamma, ts)
        C, D = c_d, d_d
    elif method == "tustin":
        A, B, C, D = _d2c_tustin(phi, gamma, c_d, d_d, ts)
    else:
        raise IdentValueError("method", "'zoh' or 'tustin'", method)
    out = control.ss(A, B, C, D)
    return control.tf(out) if isinstance(sys, control.TransferFunction) else out


def _d2c_tustin(phi: FloatArray, gamma: FloatArray, c_d: FloatArray, d_d: FloatArray, ts: float
                ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    n = phi.shape[0]
    eye = np.eye(n)
    if np.any(np.abs(np.linalg.eigvals(phi) + 1.0) < 1e-9):
        raise IdentValueError("sys", "no pole at z = -1 (tustin maps it to infinity)", "a pole at -1")
    m_inv = np.linalg.inv((phi + eye) / 2.0)
    alpha = ts / 2.0
    return ((eye - m_inv) / alpha, m_inv @ gamma / ts, c_d @ m_inv, d_d - c_d @ m_inv @ gamma / 2.0)

