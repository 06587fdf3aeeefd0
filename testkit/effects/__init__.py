"""Seeded lab runs with hidden physical effects, generated from the physics, independently of `ident`.

`make_case(seed, family)` draws a run (see `testkit.effects.draw` for the ranges), simulates it
with its own event-driven integrator (`testkit.effects.integrate`) and returns a `Case`: what a
user would pass (`case.observed`: t, y, carts) kept apart from what was hidden (`case.truth`).
"""

from testkit.effects.case import Case, Observed, Truth, write_csv
from testkit.effects.draw import FAMILIES, PAIRS, SINGLE, make_case

__all__ = ["FAMILIES", "PAIRS", "SINGLE", "Case", "Observed", "Truth", "make_case", "write_csv"]
