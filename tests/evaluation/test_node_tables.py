"""Profiles across episodes: node tables, tree against tree, triage and the heat map.

Two trees that differ in one subtree (the give-way's wait) play the same scripted missions
(tests/records/scripted_runs.py) as an evaluation's episodes would; their profiles go through
the evaluation's tables, which must find the changed subtree and nothing it did not change.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import py_trees

from bt_servicesim import dump
from bt_servicesim.evaluation.node_tables import (
    profile_tables,
    read_node_table,
    write_profile_tables,
)
from bt_servicesim.evaluation.profile_report import profile_sections
from bt_servicesim.records.profile import PROFILE_NAME
from bt_servicesim.tree.loading import DEFAULT_TREE
from tests.mission_script import Script
from tests.records.scripted_runs import play

Status = py_trees.common.Status
NOT_IN_AREA = {"RobotInPickUpArea": [Status.FAILURE] * 100_000}
#: Three missions (scripted "seeds"): blocked once on the way to the pick-up, twice, not at all.
MISSIONS = {
    1: {"GoToPickUpArea.NavigateToGoal": [Status.FAILURE, (Status.SUCCESS, 5)], **NOT_IN_AREA},
    2: {"GoToPickUpArea.NavigateToGoal": [Status.FAILURE, Status.FAILURE, (Status.SUCCESS, 5)],
        **NOT_IN_AREA},
    3: {"GoToPickUpArea.NavigateToGoal": [(Status.SUCCESS, 5)], **NOT_IN_AREA},
}
LET_PEOPLE_PASS = ("ServiceSimMission.MissionTimeLimit.Mission.PickupPhaseRetry.Pickup.FetchGuest."
                   "ApproachPickUpArea.GoToPickUpArea.NavigateWithRecovery.NavigateRecovery."
                   "ClearCostmap-Recovery.GiveWayIfBlocked.GiveWayIfBlocked.GiveWay.LetPeoplePass")


def short_wait_tree(directory: Path) -> Path:
    """The shipped tree with the give-way's wait cut from 10 to 3 sim s: one subtree changed."""
    text = DEFAULT_TREE.read_text()
    changed = text.replace('<SimWait name="LetPeoplePass" seconds="10.0"/>',
                           '<SimWait name="LetPeoplePass" seconds="3.0"/>')
    assert changed != text
    tree = directory / "short_wait.xml"
    tree.write_text(changed)
    return tree


def evaluation_rows(directory: Path, trees: dict[str, Path]) -> list[dict[str, Any]]:
    """Each tree on each scripted mission, as an evaluation's rows (profiles in their runs)."""
    rows = []
    for executive, tree in trees.items():
        for seed, outcomes in MISSIONS.items():
            out = directory / executive.replace(":", "_") / str(seed)
            run = play(out, Script(outcomes), tree_file=tree)
            (out / PROFILE_NAME).write_text(json.dumps(run.profile()))
            rows.append({"executive": executive, "scenario": "random", "episode": seed,
                         "episode_seed": seed, "completed": True, "out": str(out),
                         "reproduce": f"python -m bt_servicesim.run --seed {seed}"})
    return rows


def test_two_trees_differing_in_one_subtree_differ_there_in_the_node_table(
        tmp_path: Path) -> None:
    trees = {"bt": DEFAULT_TREE, "bt:short_wait": short_wait_tree(tmp_path)}
    tables = profile_tables(evaluation_rows(tmp_path, trees), list(trees))
    nodes = {(row["executive"], row["node"]): row for row in tables["nodes"]}
    long, short = nodes[("bt", LET_PEOPLE_PASS)], nodes[("bt:short_wait", LET_PEOPLE_PASS)]
    assert long["starts_per_episode"] == short["starts_per_episode"] == 1.0  # 3 waits / 3
    assert long["time_share"] > short["time_share"] > 0
    changed = [row["node"] for row in tables["tree_diff"]]
    assert LET_PEOPLE_PASS in changed
    assert not [node for node in changed if ".DropOff" in node or ".ReturnToStart" in node]
    recovery = next(row for row in tables["recoveries"] if row["executive"] == "bt"
                    and row["node"].endswith("GoToPickUpArea.NavigateWithRecovery."
                                             "NavigateRecovery"))
    assert recovery["fired_share"] == round(2 / 3, 4) and recovery["fired_per_episode"] == 1.0
    assert recovery["phase_succeeded_after"] == 1.0
    report = "\n".join(profile_sections(tables, list(trees)))
    assert "bt → bt:short_wait" in report and "GiveWay.LetPeoplePass" in report


def test_the_heat_map_renders_for_the_shipped_tree(tmp_path: Path) -> None:
    trees = {"bt": DEFAULT_TREE}
    write_profile_tables(tmp_path, profile_tables(evaluation_rows(tmp_path, trees), ["bt"]))
    assert read_node_table(tmp_path)
    image = tmp_path / "heat.svg"
    assert dump.main(["--heat", str(tmp_path), "--measure", "time_share", "--format", "svg",
                      "--out", str(image)]) == 0
    svg = image.read_text()
    assert "<svg" in svg and "LetPeoplePass" in svg and "time 3" in svg  # its share, in %
    assert "#ffffff" in svg.lower()  # never-waiting nodes stay cold
    source = tmp_path / "heat.dot"
    assert dump.main(["--heat", str(tmp_path), "--format", "dot", "--out", str(source)]) == 0
    assert "fillcolor" in source.read_text()


def test_a_heat_map_of_a_measure_or_executive_that_is_not_there_is_one_line(
        tmp_path: Path, capsys: Any) -> None:
    assert dump.main(["--heat", str(tmp_path), "--format", "dot", "--out",
                      str(tmp_path / "x.dot")]) == 2
    assert "profiles.json" in capsys.readouterr().err
    assert dump.main(["--heat", str(tmp_path), "--measure", "beauty", "--format", "dot",
                      "--out", str(tmp_path / "x.dot")]) == 2
    assert "--measure beauty" in capsys.readouterr().err


def test_failed_episodes_are_grouped_with_their_replay_commands(tmp_path: Path) -> None:
    out = tmp_path / "run"
    script = Script({"GoToPickUpArea.NavigateToGoal": [Status.FAILURE] * 1000, **NOT_IN_AREA})
    run = play(out, script, max_ticks=3000)
    (out / PROFILE_NAME).write_text(json.dumps(run.profile()))
    rows = [{"executive": "bt", "scenario": "hard", "episode": n, "episode_seed": 40 + n,
             "completed": False, "out": str(out), "reproduce": "python -m bt_servicesim.run"}
            for n in range(2)]
    groups = profile_tables(rows, ["bt"])["triage"]
    assert len(groups) == 1
    group = groups[0]
    assert group["count"] == 2 and group["seeds"] == [40, 41]
    assert group["phase"] == "Pickup" and group["node"] == "NavigateToGoal"
    assert group["replay"].startswith(f"python -m bt_servicesim.replay {out} --tick ")


def test_points_by_situation_add_up_per_set_and_show_in_the_results(tmp_path: Path) -> None:
    rows = evaluation_rows(tmp_path, {"bt": DEFAULT_TREE})  # three episodes
    for n, row in enumerate(rows):
        path = Path(row["out"]) / PROFILE_NAME
        profile = json.loads(path.read_text())
        profile["penalties"]["by_situation"] = {
            "approximation/walker standing for the robot": {"robot moving": float(n),
                                                            "robot standing": 2.0},
            "approximation/idler": {"robot moving": 3.0, "robot standing": 0.0}}
        path.write_text(json.dumps(profile))
    tables = profile_tables(rows, ["bt"])
    situations = {row["situation"]: row for row in tables["situations"]}
    held = situations["approximation/walker standing for the robot"]
    assert (held["points_per_episode"], held["robot_moving_per_episode"],
            held["robot_standing_per_episode"], held["share"]) == (3.0, 1.0, 2.0, 0.5)
    assert situations["approximation/idler"]["points_per_episode"] == 3.0
    report = "\n".join(profile_sections(tables, ["bt"]))
    assert ("| bt | random | approximation/walker standing for the robot | 3.0 | 1.0 | 2.0 | 50% |"
            in report)


def test_profiles_written_before_situations_were_kept_leave_the_table_out(
        tmp_path: Path) -> None:
    rows = evaluation_rows(tmp_path, {"bt": DEFAULT_TREE})
    for row in rows:
        path = Path(row["out"]) / PROFILE_NAME
        profile = json.loads(path.read_text())
        del profile["penalties"]["by_situation"]
        path.write_text(json.dumps(profile))
    tables = profile_tables(rows, ["bt"])
    assert tables["situations"] == []
    assert "Points by situation" not in "\n".join(profile_sections(tables, ["bt"]))
