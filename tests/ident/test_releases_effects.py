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
#: Drawn cases whose release must be found once and on time: all 24 of these are (23 before
#: the fine residual's window followed the noise: a hold at 972 Hz read with 0.2 mm of noise
#: was dated 8.7 samples early, seed 1706154916; earlier finders also missed coarse lattices
#: hiding a flick's end, seeds 1150721785 and 1500255062).
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


#: Holds read with heavy noise at a high rate: at a 25th of a period the fine residual's noise
#: alone was 10-40 m/s², above the spring's force that a weak, short hold lets go of.
NOISY_HOLDS = 24
NOISY_MIN_M = 1e-4           # the generator draws 5 µm-0.2 mm: its upper half-decade
NOISY_RATES_HZ = (700.0, 1000.0)
#: These 24 are all within three samples (at most 2.2); before the fine window followed the
#: noise 21 were. On 40 others (another seed) 38, before 35.
NOISY_MIN_ON_TIME = 22


def test_holds_read_with_heavy_noise_at_a_high_rate_are_dated_within_three_samples() -> None:
    rng = np.random.default_rng(20261129)
    errors: list[float] = []
    while len(errors) < NOISY_HOLDS:
        seed = int(rng.integers(2 ** 31))
        case = make_case(seed, "coulomb_friction", release="hold", rate_hz=float(rng.uniform(*NOISY_RATES_HZ)),
                         record_s=5.0)
        if case.truth.noise_m < NOISY_MIN_M:
            continue
        found = find_releases(case.observed.t, case.observed.y)
        dt = float(np.median(np.diff(case.observed.t)))
        errors.append(min((abs(f.release_time_s - case.truth.release_time_s) / dt for f in found), default=np.inf))
    on_time = sum(e <= HOLD_SAMPLES for e in errors)
    assert on_time >= NOISY_MIN_ON_TIME, sorted(round(e, 1) for e in errors)
