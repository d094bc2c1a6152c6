"""A seed is a replayable fact: the same run twice in lockstep gives the same report, and
byte-identical tree logs and profiles (py_trees' random port UUIDs kept out of them).

Two equal reports could be luck, so the test also pins what makes them equal: the tree ticked
exactly once per 0.1 sim s from its first tick to its last, which free running on a busy
machine does not (it skips ticks when the simulator runs ahead).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import pytest

from tests.fakes.commands import run_module

#: flat out, with a short time limit: the mission gets past its first two checkpoints; no
#: picture, though a mission cut short draws one by default
RUN = ["--headless", "--speed", "0", "--seed", "3", "--time-limit", "60", "--trajectory", "never"]
WALL_LIMIT_S = 400


def run(out: Path) -> tuple[dict[str, Any], str]:
    result = run_module("bt_servicesim.run", *RUN, "--out", str(out), timeout=WALL_LIMIT_S)
    return json.loads((out / "report.json").read_text()), result.stdout


def replayed(report: dict[str, Any]) -> tuple[Any, ...]:
    """What must replay: completion, checkpoint times, penalties, score."""
    return (report["completed"], [(c["done"], c["sim_time_s"]) for c in report["checkpoints"]],
            report["penalties"], report["score"])


def tick_times(out: Path) -> list[float]:
    rows = [json.loads(line) for line in (out / "tree_log.jsonl").read_text().splitlines()]
    return [row["sim_time_s"] for row in rows if row.get("kind") == "tick"]


@pytest.mark.long
def test_the_same_seed_twice_in_lockstep_gives_the_same_report(tmp_path: Path) -> None:
    first, output = run(tmp_path / "first")
    second, _ = run(tmp_path / "second")
    assert "lockstep with the simulator" in output
    assert first["timing"] == second["timing"] == "lockstep"
    assert [c["done"] for c in first["checkpoints"]][:2] == [True, True], first.get("failure")
    assert replayed(first) == replayed(second)
    for name in ("tree_log.jsonl", "profile.json"):
        assert (tmp_path / "first" / name).read_bytes() == \
            (tmp_path / "second" / name).read_bytes(), f"{name} differs"
    assert first["penalties_by_cause"] == second["penalties_by_cause"] is not None
    assert not (tmp_path / "first" / "trajectory.png").exists(), "--trajectory never drew one"
    for out, report in ((tmp_path / "first", first), (tmp_path / "second", second)):
        times = tick_times(out)
        assert report["ticks"] == len(times) > 500
        steps = {round(b - a, 6) for a, b in itertools.pairwise(times)}
        assert steps == {0.1}, f"ticks not 0.1 sim s apart: {sorted(steps)[:5]}"
        assert report["lockstep_stalls"] == 0
    replay = run_module("bt_servicesim.replay", str(tmp_path / "first"), timeout=60)
    again = f"this mission again: {first['reproduce']}"
    assert again in replay.stdout and "--seed 3 " in first["reproduce"]
