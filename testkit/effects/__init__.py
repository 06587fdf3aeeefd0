"""Seeded lab runs with hidden physical effects, generated from the physics, independently of `ident`.

`make_case(seed, family)` draws a run (see `testkit.effects.draw` for the ranges), simulates it
with its own event-driven integrator (`testkit.effects.integrate`) and returns a `Case`: what a
user would pass (`case.observed`: t, y, carts) kept apart from what was hidden (`case.truth`).
`judge(case, report)` scores a diagnosis report against that truth.
"""

from testkit.effects.case import Case, Observed, Truth, write_csv
from testkit.effects.draw import FAMILIES, PAIRS, SINGLE, make_case
from testkit.effects.judge import PARAMETER_TOL, Verdict, judge, noise_floor_percent

__all__ = [
           "FAMILIES",
           "PAIRS",
           "PARAMETER_TOL",
           "SINGLE",
           "Case",
           "Observed",
           "Truth",
           "Verdict",
           "judge",
           "make_case",
           "noise_floor_percent",
           "write_csv",
]
