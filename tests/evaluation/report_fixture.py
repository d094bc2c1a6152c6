"""A small evaluation's directory made from synthetic episodes, for the HTML report's tests.

Playing real episodes takes minutes; the page reads only files, so each episode here is the
files a run leaves: ``report.json`` with the fields a run and the evaluation write, a tree log
written by the project's own :class:`~bt_servicesim.records.tree_log.TreeLog` from a small
py_trees tree ticked on a made-up clock, ``profile.json`` built from it by the profile's own
code with points booked near a walker, and ``trajectory.png`` for each failed episode. The
evaluation's own :func:`~bt_servicesim.evaluation.report.write_results` then writes the
results, ``report.html`` among them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import py_trees
from PIL import Image

from bt_servicesim.evaluation.report import write_results
from bt_servicesim.evaluation.settings import EvaluationSettings
from bt_servicesim.records.profile import PROFILE_NAME, Booking, build_profile
from bt_servicesim.records.tree_log import LOG_NAME, TreeLog, read_records

CHECKPOINTS = ("go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start")
PHASE_TICKS = {"Pickup": 6, "Dropoff": 8}
"""Ticks each leaf of the fixture's tree runs, its last the one it succeeds on (the next leaf
starts on that tick)."""


class Ticking(py_trees.behaviour.Behaviour):
    """A leaf that runs for ``ticks`` ticks, then succeeds."""

    def __init__(self, name: str, ticks: int) -> None:
        super().__init__(name=name)
        self.ticks, self.count = ticks, 0

    def initialise(self) -> None:
        self.count = 0

    def update(self) -> py_trees.common.Status:
        self.count += 1
        self.feedback_message = f"tick {self.count}"
        return (py_trees.common.Status.SUCCESS if self.count >= self.ticks
                else py_trees.common.Status.RUNNING)


def write_tree_log(path: Path, *, seconds_per_tick: float) -> None:
    """A tree log of a two-phase mission (the phases' composite: ``Mission``)."""
    mission = py_trees.composites.Sequence(name="Mission", memory=True, children=[
        py_trees.composites.Sequence(name=f"Mission.{phase}", memory=True, children=[
            Ticking(name=f"Mission.{phase}.Go{phase}", ticks=ticks)])
        for phase, ticks in PHASE_TICKS.items()])
    tree = py_trees.trees.BehaviourTree(root=mission)
    clock = {"now": 0.0}
    log = TreeLog(tree=tree, path=path, sim_time_s=lambda: clock["now"], blackboard=dict,
                  phases="Mission")
    tick = 0
    while tree.root.status != py_trees.common.Status.SUCCESS:
        tick += 1
        clock["now"] = tick * seconds_per_tick
        tree.tick()
        log.log(tick=tick)
    log.close()


def episode_report(*, executive: str, scenario: str, episode: int, seed: int | None,
                   completed: bool, out: Path) -> dict[str, Any]:
    """The row the evaluation keeps for one episode (report.json and what it adds)."""
    score = 500.0 + 37.0 * ((episode * 7 + (executive == "baseline") * 3) % 11)
    legs = 4 if completed else 1 + episode % 3
    checkpoints = [{"name": name, "done": index < legs, "sim_time_s": 20.0 + 5.0 * index}
                   for index, name in enumerate(CHECKPOINTS)]
    reproduce = (f"python -m bt_servicesim.run{'' if seed is None else f' --seed {seed}'} "
                 f"--executive {executive} --speed 0 --time-limit 900")
    return {
        "status": "completed" if completed else "failed", "run_id": f"fixture-{out.name}",
        "seed": seed, "world": "default", "executive": executive, "timing": "lockstep",
        "reproduce": reproduce, "completed": completed, "score": score,
        "sim_time_s": sum(c["sim_time_s"] for c in checkpoints if c["done"]),
        "checkpoints": checkpoints,
        "penalties": {"failed_pickup": int(not completed), "failed_dropoff": 0, "too_fast": 0,
                      "drifts": 0, "contact": 0.0, "approximation": score - 400.0},
        "wall_time_s": 1.0, "exit_code": 0 if completed else 1,
        "failure": None if completed else "the mission time limit ran out",
        "last_activity": None if completed else "Pickup: GoPickup: tick 3",
        "not_run": False, "scenario": scenario, "episode": episode, "episode_seed": seed,
        "returncode": 0, "episode_wall_time_s": 1.0, "out": str(out),
        "revision": "commit `fixture`",
    }


def write_profile(run_dir: Path, *, points: float, end_s: float) -> None:
    """The run's profile as the run writes it (:func:`~bt_servicesim.records.profile.
    build_profile` over its tree log, to the recording's end ``end_s``), with ``points`` booked
    near a walker in two halves."""
    header, records = read_records(run_dir / LOG_NAME)
    bookings = [Booking(sim_time_s=time, sums={"approximation/walker/human_3": share})
                for time, share in ((0.0, 0.0), (6.0, points / 2), (20.0, points))]
    profile = build_profile(shape=header.shape, phases=header.phases, records=records,
                            bookings=bookings, end_s=end_s, tree_file="fixture.xml",
                            counts=header.counts)
    (run_dir / PROFILE_NAME).write_text(json.dumps(profile))


def make_evaluation(out: Path, *, episodes: int = 3) -> tuple[EvaluationSettings,
                                                               list[dict[str, Any]]]:
    """An evaluation of ``episodes`` per executive and set written to ``out``: its settings and
    rows. bt completes every episode but the last of each set; the baseline every other one."""
    settings = EvaluationSettings(
        episodes=episodes, scenarios=("default", "random"), executives=("bt", "baseline"),
        jobs=1, seed=0, out=out, speed=0.0, episode_timeout_s=60.0, time_limit_s=900.0,
        docs=None, command_line="python -m bt_servicesim.evaluate --out fixture")
    rows = []
    for scenario in settings.scenarios:
        for executive in settings.executives:
            for episode in range(episodes):
                run_dir = out / executive / scenario / str(episode)
                run_dir.mkdir(parents=True)
                completed = (episode < episodes - 1 if executive == "bt" else episode % 2 == 0)
                seed = None if scenario == "default" else episode
                row = episode_report(executive=executive, scenario=scenario, episode=episode,
                                     seed=seed, completed=completed, out=run_dir)
                (run_dir / "report.json").write_text(json.dumps(row))
                if executive == "bt":
                    write_tree_log(run_dir / LOG_NAME, seconds_per_tick=2.5)
                    write_profile(run_dir, points=row["penalties"]["approximation"],
                                  end_s=row["sim_time_s"])
                if not completed:
                    Image.new("RGB", (64, 48), (40, 90, 160)).save(run_dir / "trajectory.png")
                rows.append(row)
    write_results(settings, rows)
    return settings, rows
