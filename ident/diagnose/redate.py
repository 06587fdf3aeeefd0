"""A flick's release dated again on the fitted model (`redated_release`). No fitting, no I/O.

The window's join (`knot.flick_release`) dates a flick before anything is fitted: the hand's
cubic path joined to a free response made of the modes of the window's modal fit, with free
amplitudes and a constant, over up to a period after the let-go. Where the hand's
acceleration jumps little (generated two carts read through cart 1's encoder, jumps of
0.2-0.7 m/s² under 14-28 µm of noise at 380-930 Hz), that free part decides the join: it
cannot follow a cart's friction flipping at a velocity reversal (it only shifts the constant
between them) nor a mode the modal fit placed wrong (8.6 and 10.2 rad/s for 10.0 and 16.9), and
its free amplitudes bend to take up some of the hand's path. The join landed 1.4 and 1.5
samples early or late, and on one run 18 samples late, at the cart's first turn, where cart 1's
friction flips (`tools/bench_diagnose.py --one-encoder 20 --seed 53`: 17/20 within a sample).

Once the diagnosis has fitted the extended physical model to the whole window, its free
response is known far better than any modal guess: the chain, its friction and where each
cart reverses. So the release is dated again by joining the hand's cubic to that model run
backward in time from the window's first sample (`knot.model_join`: the free part has no
parameter left, only where the hand's path ends moves the cost), searched from the motion's
onset to the window's first sample (the fit's free response starts there: a hand that let go
later would have pushed inside it).
"""

from __future__ import annotations

import numpy as np

from ident.diagnose.fitting import FitResult, without_lattice
from ident.diagnose.knot import MIN_PRE, model_join
from ident.diagnose.problem import FloatArray
from ident.diagnose.window import Window

#: samples of the model run forward past the window's first sample (the spline's end there)
AHEAD = 4


def redated_release(t: FloatArray, y: FloatArray, win: Window, model: FitResult) -> float | None:
    """The release (s) of a flick the window's join dated (`win.flick`), joined again on the
    fitted `model` (its state at `t[win.start]`), `t` (N,) s and `y` (N, outputs) m the record
    the window cuts from; None for any other release, or when the model cannot be run backward
    (a measured input, a held cart's motion or a rest drift: known only forward on its grid) or
    its run is not finite."""
    flick, spec = win.flick, model.spec
    if flick is None or spec.held is not None or spec.inputs is not None or spec.drift is not None:
        return None
    first, start = flick.onset + 1, win.start
    if flick.output >= spec.observed or start - first < MIN_PRE or start + AHEAD >= t.size:
        return None
    dt = float(t[1] - t[0])
    # the carts' positions, not their reading: a spline through a lattice's steps has no
    # velocity to join
    spec, keep = without_lattice(spec)
    theta = model.theta[keep]
    back = spec.predict(theta[None], -dt, start - first + 1)[0, ::-1, flick.output]   # samples first..start
    ahead = spec.predict(theta[None], dt, AHEAD + 1)[0, 1:, flick.output]
    free = np.concatenate([back, ahead])
    if not np.all(np.isfinite(free)):
        return None
    stretch = slice(first, start + AHEAD + 1)
    knot = model_join(t[stretch], y[stretch, flick.output], free, MIN_PRE, start - first)
    return None if knot is None else knot.time_s


__all__ = ["AHEAD", "redated_release"]
