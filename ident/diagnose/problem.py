"""The work samples a diagnosis fits (`Problem`), and batched grid searches over one
parameter block of a model on them. No I/O here."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.models import ModelSpec

FloatArray = NDArray[np.float64]
#: (start, lower, upper, typical) of a parameter vector.
Bounds = tuple[FloatArray, FloatArray, FloatArray, FloatArray]


@dataclass(frozen=True)
class Problem:
    """Work samples of the window: `tau` (N,) s, `y` (N, carts) m, `dt` s, `train` (N,) the
    samples every fit uses (all of them), the largest swing `amplitude` (m), `held` (N,) the
    held cart's motion from its first sample (m) or None, `inputs` (N, m) or None (force inputs,
    switching within a step at `input_switch` (N, m): `ident.physics.free.switched_input`), `drift`
    (N, K) the rest drift's spline basis on knots `drift_spacing_s` apart (`drift`) or None,
    `anchor` the work samples before the blocked cross-validation's first held-out block (one
    period of the main mode; 0: the first sixth of the motion, `fitting.block_edges`),
    `still_until` the work samples the carts rest before a force input first acts (0: none)."""

    tau: FloatArray
    y: FloatArray
    dt: float
    train: NDArray[np.bool_]
    carts: int
    amplitude: float
    held: FloatArray | None = None
    inputs: FloatArray | None = None
    drift: FloatArray | None = None
    drift_spacing_s: float = 0.0
    anchor: int = 0
    input_switch: FloatArray | None = None
    still_until: int = 0


def _costs(spec: ModelSpec, prob: Problem, rows: FloatArray) -> FloatArray:
    """Sum of squared errors of each parameter row of `rows` (K, P) (one batch; a diverging
    row, such as a strong softening cubic's far start, costs inf, not a warning)."""
    with np.errstate(all="ignore"):
        pred = spec.predict(rows, prob.dt, prob.y.shape[0])
        cost: FloatArray = np.nan_to_num(np.sum((pred - prob.y[None]) ** 2, axis=(1, 2)), nan=np.inf)
    return cost


def best_rows(spec: ModelSpec, prob: Problem, theta: FloatArray, where: slice,
              values: list[FloatArray]) -> FloatArray:
    """`theta` with the block `where` set to the candidate of least cost (one batch)."""
    rows = np.array(_block_set(theta, where, values))
    return np.asarray(rows[int(np.argmin(_costs(spec, prob, rows)))], dtype=np.float64)


def _with_fixed(spec: ModelSpec, rows: list[FloatArray]) -> FloatArray:
    """`rows` as one batch (K, P), the fixed parameters set to their values."""
    batch = np.array(rows, dtype=np.float64)
    for i, name in enumerate(spec.names):
        if name in spec.fixed:
            batch[:, i] = spec.fixed[name]
    return batch


def _block_set(theta: FloatArray, where: slice, values: list[FloatArray]) -> list[FloatArray]:
    """`theta` with the block `where` set to each of `values`."""
    rows = []
    for v in values:
        row = theta.astype(np.float64).copy()
        row[where] = v
        rows.append(row)
    return rows


def cheapest(spec: ModelSpec, prob: Problem, rows: list[FloatArray], count: int) -> list[FloatArray]:
    """The `count` parameter rows of least cost, best first (one batch; the fixed parameters
    set to their values)."""
    batch = _with_fixed(spec, rows)
    return [batch[k].copy() for k in np.argsort(_costs(spec, prob, batch), kind="stable")[:count]]


def ranked_rows(spec: ModelSpec, prob: Problem, theta: FloatArray, where: slice, values: list[FloatArray],
                count: int) -> list[FloatArray]:
    """`theta` with the block `where` set to each of the `count` candidates of least cost, best
    first (one batch; the fixed parameters kept at their values)."""
    return cheapest(spec, prob, _block_set(theta, where, values), count)


def ranked_plateaus(spec: ModelSpec, prob: Problem, theta: FloatArray, where: slice, values: list[FloatArray],
                    count: int) -> list[FloatArray]:
    """As `ranked_rows`, for a block the cost is piecewise constant in (where a cart sticks
    moves by steps): neighbouring candidates of equal cost (a plateau, in `values`' order)
    count as one, and each of the `count` plateaus of least cost is started from its middle
    candidate (a plateau's edge lies next to a step the fit cannot see, and ties had always
    picked the first of the values)."""
    batch = _with_fixed(spec, _block_set(theta, where, values))
    cost = _costs(spec, prob, batch)
    runs: list[list[int]] = []
    for k in range(len(values)):
        if runs and cost[k] == cost[runs[-1][0]]:
            runs[-1].append(k)
        else:
            runs.append([k])
    runs.sort(key=lambda run: float(cost[run[0]]))
    return [batch[run[len(run) // 2]].copy() for run in runs[:count]]


def best_on_grid(spec: ModelSpec, prob: Problem, theta: FloatArray, index: int,
                 values: tuple[float, ...]) -> FloatArray:
    """`theta` with parameter `index` set to the grid value of least cost (one batch)."""
    return ranked_on_grid(spec, prob, theta, index, values, 1)[0]


def ranked_on_grid(spec: ModelSpec, prob: Problem, theta: FloatArray, index: int,
                   values: tuple[float, ...], count: int) -> list[FloatArray]:
    """`theta` with parameter `index` set to each of the `count` grid values of least cost,
    best first (one batch)."""
    return ranked_rows(spec, prob, theta, slice(index, index + 1), [np.array([v]) for v in values], count)


__all__ = ["Bounds", "FloatArray", "Problem", "best_on_grid", "best_rows", "cheapest", "ranked_on_grid",
           "ranked_plateaus", "ranked_rows"]
