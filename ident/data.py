"""Identification data: sampled input and output of one run, validated once.

Convention (written once, checked here): SI units, float seconds, time-major arrays:

- `t`: shape (N,), strictly increasing seconds;
- `u`: shape (N,), the input (for the lab: the pull distance `r(t) = d·H(t - t_r)`, metres);
- `y`: shape (N, n_outputs), cart positions in metres in the zeroed frame.

Every public entry point of `ident` that takes arrays goes through `check_arrays`, whose
errors say "expected …, got …". This module does no file I/O and no fitting.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ident import summary
from ident.errors import IdentDimensionError, IdentValueError
from ident.release import moving_outputs

FloatArray = NDArray[np.float64]

#: Fewest samples any fit accepts (a lightly damped cart needs several periods anyway).
MIN_SAMPLES = 20
#: Time stamps within this fraction of a step of a uniform grid are that grid (rounding, jitter).
GRID_TOLERANCE = 0.25
#: A median step this long (s) is taken for milliseconds: spring carts oscillate at 0.5–10 Hz, so
#: no usable record is sampled this slowly, while 1–20 ms periods written in ms give steps ≥ 1.
MS_STEP_THRESHOLD_S = 0.5


def check_arrays(t: ArrayLike, u: ArrayLike | None, y: ArrayLike,
                 min_samples: int = MIN_SAMPLES) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Validate and normalise `(t, u, y)`; return float64 `t` (N,), `u` (N,), `y` (N, n_out).

    `u=None` gives a zero input. Raises `IdentDimensionError` for shapes and
    `IdentValueError` for NaN/Inf, too few samples and non-increasing time.
    """
    t_arr = np.asarray(t, dtype=np.float64)
    if t_arr.ndim == 2 and 1 in t_arr.shape:
        t_arr = t_arr.reshape(-1)   # a column or row vector of times is still one time base
    if t_arr.ndim != 1:
        raise IdentDimensionError("t", "a 1-D array of shape (N,)", f"shape {t_arr.shape}")
    n = t_arr.shape[0]
    if n < min_samples:
        raise IdentValueError("number of samples", f"at least {min_samples}", n)
    y_arr = _as_outputs(np.asarray(y, dtype=np.float64), n)
    u_arr = np.zeros(n) if u is None else _as_input(np.asarray(u, dtype=np.float64), n)
    for name, arr in (("t", t_arr), ("u", u_arr), ("y", y_arr)):
        _check_finite(name, arr)
    steps = np.diff(t_arr)
    if np.any(steps <= 0.0):
        i = int(np.argmax(steps <= 0.0))
        kind = "duplicate" if steps[i] == 0.0 else "decreasing"
        raise IdentValueError("t", "strictly increasing time stamps",
                              f"{kind} time at index {i + 1} ({t_arr[i]!r} then {t_arr[i + 1]!r})")
    step = float(np.median(steps, overwrite_input=True))   # `steps` is ours: no copy of N floats
    if step >= MS_STEP_THRESHOLD_S:
        raise IdentValueError("t", f"seconds (a sample step below {MS_STEP_THRESHOLD_S} s)",
                              f"a median step of {step:.4g}: milliseconds? pass t / 1000 "
                              "(in a file, a column named 'time_ms' or 'Time (ms)' is scaled)")
    return t_arr, u_arr, y_arr


def _as_outputs(y: NDArray[np.float64], n: int) -> FloatArray:
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim == 2 and y.shape[0] != n and y.shape[1] == n:
        raise IdentDimensionError("y", f"time-major shape ({n},) or ({n}, n_outputs)",
                                  f"shape {y.shape} (outputs in rows): pass y.T")
    if y.ndim != 2 or y.shape[0] != n:
        raise IdentDimensionError("y", f"time-major shape ({n},) or ({n}, n_outputs)",
                                  f"shape {y.shape}")
    if y.shape[1] < 1 or y.shape[1] > 8:
        raise IdentDimensionError("y", "1 to 8 output columns", f"shape {y.shape}")
    return np.ascontiguousarray(y)


def _as_input(u: NDArray[np.float64], n: int) -> FloatArray:
    if u.ndim == 2 and u.shape[1] == 1:
        u = u[:, 0]
    if u.ndim == 2 and u.shape == (1, n):
        raise IdentDimensionError("u", f"one input of shape ({n},) or ({n}, 1)", f"shape {u.shape}: pass u.T")
    if u.ndim != 1 or u.shape[0] != n:
        raise IdentDimensionError("u", f"one input of shape ({n},) or ({n}, 1)", f"shape {u.shape}")
    return np.ascontiguousarray(u)


def _check_finite(name: str, arr: FloatArray) -> None:
    bad = ~np.isfinite(arr)
    if np.any(bad):
        index = int(np.argwhere(bad)[0][0])
        raise IdentValueError(name, "finite values", f"{arr.reshape(arr.shape[0], -1)[index]} "
                              f"at sample {index}")


#: Samples over which a coarse clock's stamps are averaged (`even_stamps`).
EVEN_SPAN = 201
#: A clock whose tick is below this fraction of the sample step is fine enough as it is (and an
#: evened clock's own steps, two values tick/EVEN_SPAN apart, are never taken for a coarse one).
MIN_TICK = 0.02
EVENED_NOTE = "time stamps of a coarse clock evened out to the sample times (ident.data.even_stamps)"


def even_stamps(t: FloatArray, y: FloatArray | None = None) -> FloatArray:
    """The sample times (N,) s of a device that stamps a coarse clock on evenly taken samples,
    evened out; any other `t` returned as it is (the same object).

    The ECP-210's Teensy stamps whole milliseconds on samples taken every ~1.128 ms: steps of
    1 and 2 ms, each stamp up to a millisecond behind its sample. Taken as sample times they
    put up to v·1 ms of error on every position (0.5 mm, 28 counts, at 0.5 m/s) and that
    much noise on every derivative and residual. Such a clock shows as steps of exactly two
    values one tick apart, each a whole number of ticks, the tick at least `MIN_TICK` of a
    step. Its stamps are replaced by their moving average over `EVEN_SPAN` samples (the
    least-squares line of each span at its middle, so a clock that drifts is followed) and,
    within half a span of either end, by the line through the first or last span, never
    outside the stamps' own span. The average keeps the stamps' time base (their mean offset
    from the samples stays). A record with a missing sample (a third step value) is left as
    it is. The same steps come from a device that takes its samples *on* the clock's ticks,
    one or two apart (a 1 kHz reader that drops frames): its stamps are its sample times.
    Given the samples `y` (N,) or (N, C), the evened times are kept only where the samples
    lie no less smoothly on them than on the stamps (`roughness`): on every real ECP export
    the evened times are 26-71 times smoother; on dropped frames they would put v·δt on
    every sample. Temporaries: a few arrays of N.
    """
    n = t.shape[0]
    if n < 2 * EVEN_SPAN:
        return t
    steps = np.diff(t)
    low, high = float(steps.min()), float(steps.max())
    tick = high - low
    if not low > 0.0 or not tick > MIN_TICK * high:
        return t
    ticks = low / tick
    if abs(ticks - round(ticks)) > 1e-6 * max(1.0, ticks):
        return t
    steps -= low
    if not np.all((steps < 1e-9 * high) | (steps > tick - 1e-9 * high)):
        return t
    del steps
    half = EVEN_SPAN // 2
    out = np.empty(n + 1)
    out[0] = 0.0
    np.cumsum(t - t[0], out=out[1:])
    out[half:n - half] = out[EVEN_SPAN:] - out[:n + 1 - EVEN_SPAN]   # span sums (numpy buffers the overlap)
    out = out[:n]
    out[half:n - half] *= 1.0 / EVEN_SPAN
    out[half:n - half] += t[0]
    k = np.arange(EVEN_SPAN, dtype=np.float64)
    for first, ends in ((0, k[:half]), (n - EVEN_SPAN, k[EVEN_SPAN - half:])):
        slope, intercept = np.polyfit(k, t[first:first + EVEN_SPAN], 1)
        out[first + ends.astype(np.intp)] = intercept + slope * ends
    np.clip(out, t[0], t[-1], out=out)
    if y is not None and roughness(out, y) > roughness(t, y):
        return t
    return out


def roughness(t: FloatArray, y: FloatArray) -> float:
    """How far the samples `y` (N,) or (N, C) stray from straight lines on the times `t` (N,):
    the sum of squared misses of each sample by the line through the two before it. A smooth
    motion misses by ~a·h² on its true sample times and by ~v·δt on times δt off them."""
    if t.shape[0] < 3:
        return 0.0
    h = np.diff(t)
    ratio = (h[1:] / np.where(h[:-1] > 0.0, h[:-1], np.inf)).reshape(-1, *([1] * (y.ndim - 1)))
    dy = np.diff(y, axis=0)
    return float(np.sum(np.square(dy[1:] - ratio * dy[:-1])))


@dataclass(frozen=True)
class IdData:
    """One run: time `t` (N,) s, input `u` (N,), outputs `y` (N, n_outputs) m.

    `release_time_s` (float, not rounded to a sample) is the release instant when known
    (from the run's metadata); `pulled_cart` is 1 or 2 when known. Construct as
    `IdData(t, u, y)`; arrays are validated and copied read-only. Stamps of a coarse clock
    (`even_stamps`: the ECP Teensy's whole ms on ~1.13 ms samples) are taken as the sample
    times they stand for, evened out, and `notes` says so.
    """

    t: FloatArray
    u: FloatArray
    y: FloatArray
    release_time_s: float | None = None
    pulled_cart: int | None = None
    name: str = ""
    notes: tuple[str, ...] = field(default=())
    columns: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        t, u, y = check_arrays(self.t, self.u, self.y)
        stamps, t = t, even_stamps(t, y)
        if t is not stamps:
            object.__setattr__(self, "notes", (*self.notes, EVENED_NOTE))
            if self.release_time_s is not None and stamps[0] <= self.release_time_s <= stamps[-1]:
                # a release within the stamps stays within the evened times (they move less than a tick)
                object.__setattr__(self, "release_time_s", float(np.clip(self.release_time_s, t[0], t[-1])))
        for attr, arr in (("t", t), ("u", u), ("y", y)):
            if arr.flags.writeable or not arr.flags.owndata:
                arr = arr.copy()   # ours alone, read-only (a read-only array that owns its data is shared:
                arr.flags.writeable = False   # `replace` and loaders do not double a large record)
            object.__setattr__(self, attr, arr)
        if self.release_time_s is not None:
            if not np.isfinite(self.release_time_s) or not t[0] <= self.release_time_s <= t[-1]:
                raise IdentValueError("release_time_s", f"a time within [{t[0]}, {t[-1]}] s",
                                      self.release_time_s)
            object.__setattr__(self, "release_time_s", float(self.release_time_s))

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_outputs(self) -> int:
        return int(self.y.shape[1])

    @property
    def step_amplitude(self) -> float:
        """`u[-1]`: the size of the step from the input's rest at 0 (m for the lab's position
        step; `input_jumps`)."""
        return float(self.u[-1])

    def step_time(self) -> float | None:
        """Time of the first sample where `u` leaves its initial value (None if constant)."""
        moved = np.flatnonzero(self.u != self.u[0])
        return float(self.t[moved[0]]) if moved.size else None

    def sample_time(self) -> float:
        """The sample period Ts (s): the slope of a least-squares line through `t`."""
        return _line(self.t)[1]

    def is_uniform(self, tolerance: float = GRID_TOLERANCE) -> bool:
        """True when every stamp is within `tolerance`·Ts of the uniform grid through `t`."""
        return _grid_deviation(self.t) <= tolerance

    def select_outputs(self, columns: list[int]) -> IdData:
        """The same run with only the output columns `columns` (0-based)."""
        if not columns or any(not 0 <= c < self.n_outputs for c in columns):
            raise IdentValueError("columns", f"indices in 0 … {self.n_outputs - 1}", columns)
        names = tuple(self.columns[i] for i in columns) if self.columns else ()
        return IdData(self.t, self.u, self.y[:, columns], self.release_time_s,
                      self.pulled_cart, self.name, self.notes, names)

    def cart_numbers(self) -> tuple[int, ...]:
        """The cart each output column reads: the number in its name ('Encoder 2 Pos',
        'pos2_m' -> 2), else its position (1, 2, ...). Figures and reports label by these. The
        names a file without a header gets ('col3', `ident.text_table`) number columns, not
        carts: x1 and x2 of the PoliMi record (col3, col5) had been labelled carts 3 and 5."""
        if any(re.fullmatch(r"col\d+", name) for name in self.columns):
            return tuple(range(1, self.n_outputs + 1))
        found = [re.findall(r"\d+", name) for name in self.columns]
        numbers = tuple(int(f[-1]) if f else i + 1 for i, f in enumerate(found))
        if len(numbers) != self.n_outputs or len(set(numbers)) != len(numbers) or 0 in numbers:
            return tuple(range(1, self.n_outputs + 1))
        return numbers

    def summary_rows(self) -> list[tuple[str, str]]:
        """The labelled lines of `repr` and `_repr_html_`."""
        ts = self.sample_time()
        grid = "uniform" if self.is_uniform() else "NOT uniform: ident.make_uniform(data)"
        rows = [("samples", f"{self.n_samples}, Ts = {ts:.4g} s ({1 / ts:.4g} Hz), {grid}"),
                ("time", summary.span(self.t, "s"))]
        moving = moving_outputs(self.y) if self.n_samples >= MIN_SAMPLES else list(range(self.n_outputs))
        for j in range(self.n_outputs):
            state = "moving" if j in moving else "held (no motion)"
            column = f" ({self.columns[j]})" if j < len(self.columns) else ""
            rows.append((f"y{j + 1}", f"{summary.span(self.y[:, j], 'm')}, {state}{column}"))
        if moving and len(moving) < self.n_outputs:
            rows.append(("hint", f"fit the moving outputs: data.select_outputs({moving})"))
        rows.append(("input u", self._input_summary()))
        if self.release_time_s is not None:
            rows.append(("release", f"{self.release_time_s:.4f} s"))
        if self.pulled_cart is not None:
            rows.append(("pulled cart", str(self.pulled_cart)))
        rows.extend(("note", note) for note in self.notes)
        return rows

    def _input_summary(self) -> str:
        """'step of A at T s' for a step, else the range and the first change of a recorded input
        (and whether it is on at the first sample: the models start from rest at a zero input,
        `input_jumps`, so such an input acts from there)."""
        start = self.step_time()
        on = f", on at the first sample ({self.u[0]:.4g}: acting from there)" if self.u[0] != 0.0 else ""
        if start is None:
            return f"constant {self.u[0]:.4g}{on}"
        if not on and self.step_amplitude != 0.0 and np.unique(self.u).size == 2 \
                and np.all(np.diff(self.u) * self.step_amplitude >= 0):
            return f"step of {self.step_amplitude:.4g} at {start:.4g} s"
        return (f"recorded, {float(np.min(self.u)):.4g} … {float(np.max(self.u)):.4g}{on}, "
                f"first change at {start:.4g} s")

    def _title(self) -> str:
        name = f" {self.name!r}" if self.name else ""
        return f"IdData{name}: {self.n_outputs} output(s), 1 input"

    def __repr__(self) -> str:
        return summary.text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary.html_table(self._title(), self.summary_rows())


def _line(t: FloatArray) -> tuple[FloatArray, float]:
    """The least-squares line a + b k through the stamps `t` (N,), and its step b."""
    k = np.arange(t.shape[0], dtype=np.float64)
    slope, intercept = np.polyfit(k, t, 1)
    line: FloatArray = intercept + slope * k
    return line, float(slope)


def _grid_deviation(t: FloatArray) -> float:
    """max |t_k - (a + b k)| / b for the least-squares line a + b k."""
    line, slope = _line(t)
    return float(np.max(np.abs(t - line)) / slope)


def stamps_line(t: FloatArray) -> FloatArray:
    """Nearly even stamps `t` (N,) as their least-squares line t0 + k·Ts, or `t` itself when its
    steps agree to 1e-9: code that indexes samples by t0 + k·Ts or steps a simulation by one
    step then agrees with the stamps (a first step 0.9 % short of the others had set both),
    and stamps already even stay bit for bit what they were (a diagnosis of dry friction can
    turn on a rounding of its step)."""
    dt = np.diff(t)
    if dt.size == 0 or float(np.ptp(dt)) <= 1e-9 * abs(float(np.median(dt))):
        return t
    return _line(t)[0]


def uniform_grid(t: FloatArray, y: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """(the sample times `even_stamps(t, y)`, a uniform grid from their first over their span).

    The grid's step is the median step of the times, or for an evened clock (whose steps are
    even but not equal) their mean step; the grid never passes the last time.
    """
    times = even_stamps(t, y)
    ts = float(np.median(np.diff(times))) if times is t else float(times[-1] - times[0]) / (times.shape[0] - 1)
    n = int(np.floor((times[-1] - times[0]) / ts + 1e-9)) + 1
    return times, np.minimum(times[0] + ts * np.arange(n), times[-1])


def make_uniform(data: IdData, method: Literal["auto", "grid", "linear"] = "auto") -> IdData:
    """Return `data` on a uniform time grid, stating what was done in `notes`.

    - `grid`: replace the stamps by the least-squares line `t0 + k·Ts` (right when stamps
      were rounded on printing or jitter around a regular clock: ECP exports print 3 decimals
      of an 8.85 ms period);
    - `linear`: resample `u` and `y` by linear interpolation onto `t0 + k·Ts` with `Ts` the
      median step (right for missing samples and truly irregular clocks; it low-passes a
      little: error ≤ h²/8·max|y''|) (a coarse clock's stamps were evened out when `data`
      was built: `IdData`);
    - `auto`: `grid` when every stamp is within `GRID_TOLERANCE`·Ts of the grid, else `linear`.
    The input is resampled with zero-order hold (it is a step), not interpolated.
    """
    if method == "auto":
        method = "grid" if data.is_uniform() else "linear"
    if method == "grid":
        ts = data.sample_time()
        grid = data.t[0] + ts * np.arange(data.n_samples)
        note = f"time stamps replaced by the least-squares grid, Ts = {ts:.6g} s"
        return IdData(grid, data.u, data.y, data.release_time_s, data.pulled_cart, data.name,
                      (*data.notes, note), data.columns)
    t, grid = uniform_grid(data.t, data.y)
    ts = float(grid[1] - grid[0])
    y = np.column_stack([np.interp(grid, t, col) for col in data.y.T])
    hold = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, data.n_samples - 1)
    note = f"resampled by linear interpolation onto a uniform grid, Ts = {ts:.6g} s"
    return IdData(grid, data.u[hold], y, data.release_time_s, data.pulled_cart, data.name,
                  (*data.notes, note), data.columns)


def input_jumps(u: FloatArray) -> NDArray[np.intp]:
    """Indices i where the input `u` (N,) changes between samples i and i + 1, with -1 first
    when it is already on at the first sample: a force switched on as the record starts (the
    2023 open-loop steps `DOF1_en1_input1_test4` and `test5` read 0.5 V from their first
    sample, their cart at rest at 0 and moving from there; their one recorded change, the
    drive's reversal at 3.0 s, had been fitted as a release from rest: 76 % instead of 95 %).
    The lab's release step (`step_input`) starts at 0: every model here starts from rest at a
    zero input (`ident.modal.input_basis`)."""
    jumps = np.flatnonzero(np.diff(u) != 0.0)
    return np.concatenate([[-1], jumps]) if u.size and u[0] != 0.0 else jumps


def step_input(t: ArrayLike, release_time_s: float, amplitude: float) -> FloatArray:
    """`u_k = amplitude · H(t_k - release_time_s)`; H(0) = 1. Shape (N,).

    The release time is a float and is kept as such by the fitters; this sampled `u` is only
    the zero-order-hold picture of it on the sample grid.
    """
    t_arr = np.asarray(t, dtype=np.float64)
    return np.where(t_arr >= release_time_s, float(amplitude), 0.0)


def from_release(t: ArrayLike, y: ArrayLike, release_time_s: float | None,
                 amplitude: float = 0.15, pulled_cart: int | None = None,
                 name: str = "") -> IdData:
    """Build `IdData` for a release run: the step input from a (float) release time.

    The release time is required: a record whose release is not known has it found by
    `ident.releases.with_found_release` (the release finder, ident's one estimator).
    """
    t_arr, _, y_arr = check_arrays(t, None, y)
    if release_time_s is None:
        raise IdentValueError("release_time_s", "a release time (s) on the record's time base; to find it "
                              "in the data use ident.releases.with_found_release(t, y) or `ident releases`",
                              None)
    return IdData(t_arr, step_input(t_arr, release_time_s, amplitude), y_arr, release_time_s,
                  pulled_cart, name, ())
