"""`ident.releases.find_releases` on runs with an effect its free model lacks
(`testkit.effects`: its own event-driven integrator, independent of the finder).

The finder's free model is linear springs with viscous, dry and quadratic-drag friction; a
run with quadratic drag at a large swing, a second mode, a cubic spring, Coulomb friction or
a coarse encoder lattice still has exactly one release: the hand's episode ending, then free
motion. The single-effect families of `testkit.effects.SINGLE` at their full ranges (one or
two carts, hold or flick, 50–1000 Hz), drawn by seed: the release is found once, at the
generator's instant within three samples after a hold (the hand lets go of the spring's
whole force) and within a tenth of a period after a flick (the hand lets go near the first
extreme, where its force may be down to the noise).
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.releases import find_releases
from testkit.effects import SINGLE, make_case

#: An independent case in which the finder once found no release (quadratic drag on a 19 cm
#: hold at 641 Hz).
KNOWN = ((2035121339, "quadratic_drag"),)
N_DRAWN = 24
#: Drawn cases whose release must be found once and on time: 21 of these 24 are. The rest:
#: a coarse lattice hiding a flick's end (seeds 1150721785 and 1500255062: no release, and
#: 16 samples early), and a hold at 972 Hz read with 0.2 mm of noise dated 8.7 samples early
#: (1706154916). On 60 other draws (scratch survey), 55 pass: two coarse-lattice flicks, two
#: second modes (a hold and a flick: the second mode's misfit early in the free response is
#: taken for the hand again within a period) and a cubic-spring flick 12 samples early.
MIN_FOUND = 0.85
HOLD_SAMPLES = 3.0
FLICK_PERIODS = 0.1


def _problem(seed: int, family: str) -> str | None:
    """Why the case's release is not found once and on time (None when it is)."""
    case = make_case(seed, family)
    t, y = case.observed.t, case.observed.y
    found = find_releases(t, y)
    if len(found) != 1:
        return f"{seed} {family} {case.truth.release}: {len(found)} releases"
    dt = float(np.median(np.diff(t)))
    error = found[0].release_time_s - case.truth.release_time_s
    tol = HOLD_SAMPLES * dt if case.truth.release == "hold" else FLICK_PERIODS * found[0].period_s
    return None if abs(error) <= tol else f"{seed} {family} {case.truth.release}: {error / dt:+.1f} samples"


@pytest.mark.parametrize(("seed", "family"), KNOWN)
def test_a_release_the_unmodelled_force_once_hid_is_found(seed: int, family: str) -> None:
    assert _problem(seed, family) is None


def test_releases_of_runs_with_unmodelled_effects_are_found_on_time() -> None:
    rng = np.random.default_rng(20261124)
    plan = [(int(rng.integers(2 ** 31)), SINGLE[i % len(SINGLE)]) for i in range(N_DRAWN)]
    problems = [p for seed, family in plan if (p := _problem(seed, family))]
    assert len(problems) <= (1.0 - MIN_FOUND) * N_DRAWN, problems
