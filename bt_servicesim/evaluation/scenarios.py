"""The scenario sets an evaluation plays: which tasks, and which simulator knobs.

Each set is a list of episodes on the same footing for every executive: the shipped task, or
seeded random tasks with the simulator's difficulty knobs as the set names them
(docs/reference/evaluation.md describes them).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ScenarioSet:
    """How the episodes of one set are run: seeded or the shipped task, extra simulator args."""

    name: str
    seeded: bool
    sim_args: tuple[str, ...] = ()
    description: str = ""


SCENARIO_SETS = {
    scenario.name: scenario for scenario in (
        ScenarioSet("default", seeded=False, description="the shipped task"),
        ScenarioSet("random", seeded=True, description="seeded random tasks"),
        ScenarioSet("hard", seeded=True, sim_args=("--difficulty", "hard"),
                    description="seeded random tasks, every difficulty knob turned up"),
        ScenarioSet("original-guest", seeded=True, sim_args=("--guest-path", "straight"),
                    description="the random set's tasks with the original's guest, who walks "
                    "straight at the robot (through walls) instead of along its trail"),
    )
}
