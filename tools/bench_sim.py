"""Speed of the simulated rig's physics: cart steps per second of CPU, free and hand-held.

Each scenario drives the sim core (`daq.sim.rig.Rig`, no port) through `--seconds` of
simulated time at `rate_hz=200`, `substep_hz=2000` (10 physics steps per sample), and times
the rig's `_advance_to` (the physics, with the hand's paths) apart from the line encoding.
Scenarios: the scripted `cases=both` (pull, hold, release: about half the time held) without
and with dry friction, a cubic spring, and a seeded student (`student=releases`).

    python tools/bench_sim.py                 # 120 s simulated per scenario
    python tools/bench_sim.py --seconds 20
"""

from __future__ import annotations

import argparse
import time

from daq.sim.options import parse_sim_url
from daq.sim.rig import Rig

SCENARIOS: dict[str, str] = {
    "both, viscous": "cases=both",
    "both, dry friction": "cases=both&fc1=0.3&fc2=0.3",
    "both, cubic spring": "cases=both&cubic=20",
    "student releases, friction": "student=releases&fc1=0.2&fc2=0.2",
}


def measure(query: str, seconds: float, seed: int) -> tuple[float, float, float]:
    """(physics steps per CPU second, share of the time held, samples per CPU second)."""
    rig = Rig(parse_sim_url(f"sim://?realtime=0&rate_hz=200&substep_hz=2000&seed={seed}&"
                            f"duration_s={seconds}&{query}"))
    inner = rig._advance_to
    spent = [0.0]
    held = [0, 0]

    def timed(t: float) -> None:
        start = time.process_time()
        inner(t)
        spent[0] += time.process_time() - start
        held[0] += rig.hand.path1 is not None or rig.hand.path2 is not None
        held[1] += 1

    rig._advance_to = timed  # type: ignore[method-assign]
    start = time.process_time()
    while not rig.finished:
        rig.produce_bytes(1 << 16)
        rig.take(1 << 20)
    total = time.process_time() - start
    steps = rig.stats.samples * 10
    return steps / max(spent[0], 1e-9), held[0] / max(held[1], 1), rig.stats.samples / max(total, 1e-9)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=120.0, help="simulated seconds per scenario")
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args(argv)
    measure("cases=cart1", 2.0, args.seed)              # compile / load the kernel once
    print(f"{'scenario':30s} {'steps/s (physics)':>18s} {'held %':>7s} {'samples/s (rig)':>16s}")
    for name, query in SCENARIOS.items():
        rate, held, samples = measure(query, args.seconds, args.seed)
        print(f"{name:30s} {rate:18,.0f} {100 * held:7.1f} {samples:16,.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
