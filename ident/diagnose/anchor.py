"""The blocked cross-validation's anchoring stretch: one period of the window's main mode, or a
sixth of the window when its carts end stuck by dry friction (`anchor_of`); a forced window's
start state, at rest until its input acts (`still_until`, `still_start`). No I/O."""

from __future__ import annotations

import numpy as np

from ident.diagnose.problem import FloatArray, Problem
from ident.diagnose.select import ALPHA
from ident.diagnose.window import Window
from ident.physics.measures import noise_std

#: Work samples the blocked cross-validation's anchoring stretch holds at least.
MIN_ANCHOR = 10

# a forced window still for at least this many work samples before its input first switches
# starts at rest there (`still_start`)
MIN_STILL_START = 10


def anchor_of(win: Window, dt: float, fine: FloatArray, y: FloatArray) -> int:
    """The cross-validation's anchoring stretch (`fitting.block_edges`) for the work samples
    `y` (N, c) (`fine` (M, c): every sample of the window, `dt` s apart): one period of the
    window's main mode (`MIN_ANCHOR` samples at least), enough to fix the release state of
    carts that ring freely; 0 (a sixth of the window) when the window has no period (a force
    input's whole record) or its carts end stuck (still within the noise and not swinging at
    the main period: `rings_at_end`).

    A cart that sticks has its release state fixed by the rest of the record only through a
    chaotic extrapolation back across every stick: a held-out block right after one period
    then judges how a refit without it extrapolates, not the effect (generated Coulomb runs with
    a held cart, seeds 144445060 and 1568247562: the held cart's gain 6-30 % off with the short
    anchor)."""
    if not np.isfinite(win.period_s) or win.period_s <= 0:
        return 0
    period = max(round(win.period_s / (dt * win.decimation)), MIN_ANCHOR)
    stuck = ends_stuck(y, period) and not rings_at_end(fine, max(round(win.period_s / dt), 1))
    return 0 if stuck else period


def ends_stuck(y: FloatArray, period: int) -> bool:
    """Whether every output's last `period` samples stay within 6 noise σ (second-difference
    estimate, `noise_std`) plus the reading's step (the smallest nonzero change) of their
    median: a cart held by dry friction, not one still ringing."""
    tail = y[-period:]
    if tail.shape[0] < 5:
        return False
    sigma = noise_std(y)
    steps = np.abs(np.diff(tail, axis=0))
    step = np.array([float(np.min(c[c > 0])) if np.any(c > 0) else 0.0 for c in steps.T])
    return bool(np.all(np.max(np.abs(tail - np.median(tail, axis=0)), axis=0) <= 6.0 * sigma + step))


#: Samples of the last period `rings_at_end` needs for its F-test.
MIN_RING_SAMPLES = 8


def rings_at_end(fine: FloatArray, period: int) -> bool:
    """Whether some output of `fine` (M, c), every sample of the window, still swings at the
    main period over its last `period` samples: the F-test of a cosine and sine of that period
    beside a constant and a slope (a drifting rest), F = (ΔSS/2) / (SS/(m-4)) against
    F_{2,m-4}(1 - ALPHA), the tail's own scatter (noise and encoder steps) as the noise.

    A viscous ring decays exponentially and never stops: its last swings sink into the noise
    but keep their period, where a cart held by dry friction reads one level plus noise.
    `ends_stuck` cannot tell them apart below 6 σ, and its σ, from the work samples'
    second differences, includes the motion's curvature at a few samples per period (red
    team `coupled_pinned` 2903, 279 Hz, one sample in 8: 1.0 mm for a noise of 0.23 mm): a
    3.5 Hz cart still swinging 0.7 mm at the end of 15 s was taken as stuck, the anchor was a
    sixth of the window (2.5 s), and the 6.5 Hz mode, decaying at 1.2 /s, lay in it (held-out
    ratio 15.9 against a bound of 29.4; 189 with one period's anchor)."""
    import scipy.stats  # deferred: keeps `import ident` fast

    tail = fine[-period:]
    m = tail.shape[0]
    if m < MIN_RING_SAMPLES:
        return False
    phase = 2.0 * np.pi * np.arange(m) / period
    slow = np.column_stack([np.ones(m), phase])
    swing = np.column_stack([slow, np.cos(phase), np.sin(phase)])
    bar = float(scipy.stats.f.ppf(1.0 - ALPHA, 2, m - 4))
    for column in tail.T:
        ss_slow = float(np.sum((column - slow @ np.linalg.lstsq(slow, column, rcond=None)[0]) ** 2))
        ss_swing = float(np.sum((column - swing @ np.linalg.lstsq(swing, column, rcond=None)[0]) ** 2))
        if ss_slow <= 0.0:   # one level throughout: still
            continue
        if (ss_slow - ss_swing) / 2.0 > bar * max(ss_swing, 1e-300) / (m - 4):
            return True
    return False


def still_until(inputs: FloatArray, y: FloatArray) -> int:
    """The work samples (`MIN_STILL_START` at least) the carts `y` (N, c) rest still before the
    force `inputs` (N, m) first switch; 0 when they move before, or it never switches."""
    changed = np.flatnonzero(np.any(inputs != inputs[0], axis=1))
    if changed.size == 0 or changed[0] < MIN_STILL_START:
        return 0
    return int(changed[0]) if ends_stuck(y[:changed[0]], int(changed[0])) else 0


def still_start(prob: Problem) -> dict[str, float]:
    """A forced window whose carts rest until its input first switches (`Problem.still_until`,
    from `still_until`) starts at rest: x0 the still position, v0 0. Fitted freely, the state at the window start
    rang the linear model before the input acted (a 2025 ECP-210 motor pulse's daq run, cart at
    rest for 0.5 s) and took up misfit of the response after it."""
    if not prob.still_until:
        return {}
    still = np.median(prob.y[:prob.still_until], axis=0)
    fixed = {f"x0_{i + 1}_m": float(still[i]) for i in range(min(prob.carts, still.size))}
    return {**fixed, **{f"v0_{i + 1}_m_s": 0.0 for i in range(prob.carts)}}
