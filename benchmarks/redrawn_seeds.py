"""Which seeds play a later draw of their task, and what finding a playable draw costs.

``python benchmarks/redrawn_seeds.py [--seeds 100]`` draws the office's task for seeds 0..N-1,
with the default knobs and with ``--difficulty hard``, as the simulator does at a reset
(:func:`servicesim_sim.model.playable.playable_engine`: no mission is played), and prints for
each the seeds whose first draw cannot be played with the draw each plays instead, and the
mean wall time per seed of building its playable engine.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence

from bt_servicesim.cli import OneLineArgumentParser
from servicesim_sim.model.playable import MAX_DRAWS, playable_engine
from servicesim_sim.model.scenario import Difficulty, make_scenario
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world


def later_draws(world: World, *, seeds: int, difficulty: Difficulty) -> tuple[
        list[tuple[int, int]], float]:
    """(seed, draw played) for the seeds not playing draw 0, and mean seconds per seed."""
    later = []
    began = time.perf_counter()
    for seed in range(seeds):
        engine = playable_engine(world, seed=seed, difficulty=difficulty)
        draw = next(draw for draw in range(MAX_DRAWS) if make_scenario(
            world, seed=seed, difficulty=difficulty, draw=draw) == engine.scenario)
        if draw:
            later.append((seed, draw))
    return later, (time.perf_counter() - began) / max(seeds, 1)


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--seeds", type=int, default=100, help="seeds 0..N-1 (default 100)")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error(f"--seeds {args.seeds}: must be 1 or more")
    world = load_world(DEFAULT_WORLD)
    for name, difficulty in (("default", Difficulty.default()), ("hard", Difficulty.hard())):
        later, mean_s = later_draws(world, seeds=args.seeds, difficulty=difficulty)
        listed = ", ".join(f"{seed} (draw {draw})" for seed, draw in later) or "none"
        print(f"{name}: {len(later)} of {args.seeds} seeds play a later draw: {listed}; "
              f"{mean_s * 1000:.0f} ms per seed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
