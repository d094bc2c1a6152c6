"""A stand-in for the simulator's bound command, for evaluation tests that do not test bounds.

``python -c FAKE_BOUND_COMMAND LOG --episodes FILE`` answers every entry with a bound of
``50 + 10 * seed`` seconds (50 for the shipped task) and appends the entries it was asked for,
one JSON list a line, to ``LOG``: a test can count the calls and what each asked.
"""

from __future__ import annotations

import sys
from pathlib import Path

FAKE_BOUND_COMMAND = r"""
import json, sys
log, flag, path = sys.argv[1:4]
entries = json.load(open(path))
with open(log, "a") as stream:
    stream.write(json.dumps(entries) + "\n")
answers = [{"world": entry["world"], "seed": entry["seed"],
            "bound_s": 50.0 + 10.0 * (entry["seed"] or 0),
            "legs": [{"checkpoint": "go_to_pick_up", "length_m": 1.0, "bound_s": 2.0,
                      "end": [0.0, 0.0]}]} for entry in entries]
print(json.dumps(answers))
"""


def fake_bound_command(log: Path | str) -> tuple[str, ...]:
    return (sys.executable, "-c", FAKE_BOUND_COMMAND, str(log))


def fake_bound(seed: int | None) -> float:
    """The bound the fake gives an episode of ``seed``."""
    return 50.0 + 10.0 * (seed or 0)
