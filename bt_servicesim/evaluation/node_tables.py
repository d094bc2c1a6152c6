"""Profiles across episodes: per executive and scenario set, where the time and points went.

Design intent: each episode's ``profile.json`` (:mod:`bt_servicesim.records.profile`) says why
one mission went as it did; these tables say it for an executive over a whole evaluation, as
plain rows (no ROS, no py_trees), written as CSV and JSON in the evaluation directory by
:func:`write_profile_tables` and drawn on the tree by ``python -m bt_servicesim.dump --heat``:

``nodes``
    per node (its path in the tree): ``ran_share`` (share of episodes in which it started),
    ``starts_per_episode``, ``failure_rate`` (failures over outcomes), ``running_s`` (sim s
    RUNNING per episode), ``time_share`` (its RUNNING sim time over all the episodes' sim
    time), ``tip_share`` (the same as the tip), ``points_tip`` and ``points_under`` per
    episode;
``recoveries``
    per ``Retry`` and ``RecoveryNode``: ``fired_share`` (share of episodes in which it fired),
    ``fired_per_episode``, and ``phase_succeeded_after`` (of the episodes in which it fired, the
    share whose phase then succeeded);
``phases``
    per phase: sim time, share of the kinematic bound and time over it, points by cause (per
    episode), and the proxemic zones' shares (guest apart from everyone else);
``situations``
    per penalty and what the person near was doing (a walker walking, a walker standing for the
    robot, ...; :mod:`bt_servicesim.records.situations`): points per episode, with the robot
    moving and standing;
``triage``
    failed episodes grouped by the phase they reached, the node that failed last and the
    reason, each group with its seeds, the ``run`` command that replays one and the ``replay``
    command that shows the tree when the phase's last attempt failed;
``tree_diff``
    for every pair of trees played, the nodes they share whose figures changed most.
"""

from __future__ import annotations

import csv
import json
import re
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Any

from bt_servicesim.records.situations import ROBOT_MOVING, ROBOT_STANDING

PROFILE_NAME = "profile.json"  # as bt_servicesim.records.profile writes it
TABLES_NAME = "profiles.json"
MEASURES = ("time_share", "failure_rate", "points_tip", "points_under", "starts_per_episode",
            "ran_share", "tip_share")
"""The node figures a heat map can colour by."""
DIFF_MEASURES = ("ran_share", "starts_per_episode", "failure_rate", "running_s",
                 "points_under")
"""What a tree against tree comparison compares: per episode, not shares of the whole (a tree
that saves time elsewhere changes every node's share of it)."""
DIFF_TOP = 10
NUMBER = re.compile(r"-?\d+(\.\d+)?")


@dataclass(frozen=True)
class Episode:
    """One played episode's row (report fields and where it ran) and its profile, if any."""

    row: Mapping[str, Any]
    profile: Mapping[str, Any] | None

    @property
    def group(self) -> tuple[str, str]:
        return str(self.row.get("executive")), str(self.row.get("scenario"))

    @property
    def figures(self) -> Mapping[str, Any]:
        """The profile of an episode that has one (every episode of a group has)."""
        if self.profile is None:
            raise ValueError(f"episode {self.row.get('out')!r} has no profile")
        return self.profile


def load_episodes(rows: Iterable[Mapping[str, Any]]) -> list[Episode]:
    """The played rows with the profiles their runs wrote (``None`` where there is none)."""
    episodes = []
    for row in rows:
        if row.get("not_run"):
            continue
        profile = None
        if row.get("out"):
            try:
                profile = json.loads((Path(str(row["out"])) / PROFILE_NAME).read_text())
            except (OSError, ValueError):
                profile = None
        episodes.append(Episode(row=row, profile=profile))
    return episodes


def _groups(episodes: Iterable[Episode]) -> dict[tuple[str, str], list[Episode]]:
    groups: dict[tuple[str, str], list[Episode]] = {}
    for episode in episodes:
        if episode.profile is not None:
            groups.setdefault(episode.group, []).append(episode)
    return groups


# ------------------------------------------------------------------------------------- nodes
def node_rows(episodes: Sequence[Episode]) -> list[dict[str, Any]]:
    """The ``nodes`` table: one row per executive, set and node (see the module docstring)."""
    rows = []
    for (executive, scenario), group in sorted(_groups(episodes).items()):
        count = len(group)
        sim_time = sum(float(episode.figures["sim_time_s"]) for episode in group) or 1.0
        figures: dict[str, list[Mapping[str, Any]]] = {}
        for episode in group:
            for key, node in episode.figures["nodes"].items():
                figures.setdefault(key, []).append(node)
        for key, nodes in figures.items():
            first = nodes[0]
            outcomes = sum(node["success"] + node["failure"] for node in nodes)
            rows.append({
                "executive": executive, "scenario": scenario, "node": key,
                "label": first.get("label", key.rsplit(".", 1)[-1]),
                "type": first.get("type", ""), "phase": first.get("phase", "-"),
                "episodes": count,
                "ran_share": _r(sum(node["starts"] > 0 for node in nodes) / count),
                "starts_per_episode": _r(sum(node["starts"] for node in nodes) / count),
                "failure_rate": _r(sum(node["failure"] for node in nodes) / outcomes)
                if outcomes else None,
                "running_s": _r(sum(node["running_s"] for node in nodes) / count),
                "time_share": _r(sum(node["running_s"] for node in nodes) / sim_time),
                "tip_share": _r(sum(node["tip_s"] for node in nodes) / sim_time),
                "points_tip": _r(sum(node["points_tip"] for node in nodes) / count),
                "points_under": _r(sum(node["points_under"] for node in nodes) / count),
            })
    return rows


def recovery_rows(episodes: Sequence[Episode]) -> list[dict[str, Any]]:
    """The ``recoveries`` table: every Retry and RecoveryNode (see the module docstring)."""
    rows = []
    for (executive, scenario), group in sorted(_groups(episodes).items()):
        keys = [key for key, node in group[0].figures["nodes"].items() if "fired" in node]
        for key in keys:
            fired = [episode for episode in group
                     if episode.figures["nodes"].get(key, {}).get("fired", 0) > 0]
            succeeded = [episode for episode in fired if _phase_succeeded(episode, key)]
            node = group[0].figures["nodes"][key]
            rows.append({
                "executive": executive, "scenario": scenario, "node": key,
                "label": node.get("label", key), "type": node.get("type", ""),
                "phase": node.get("phase", "-"), "episodes": len(group),
                "fired_share": _r(len(fired) / len(group)),
                "fired_per_episode": _r(sum(episode.figures["nodes"].get(key, {}).get("fired", 0)
                                            for episode in group) / len(group)),
                "phase_succeeded_after": _r(len(succeeded) / len(fired)) if fired else None,
            })
    return rows


def _phase_succeeded(episode: Episode, key: str) -> bool:
    phase = episode.figures["nodes"][key].get("phase")
    return any(entry["phase"] == phase and entry.get("succeeded")
               for entry in episode.figures["phases"])


# ------------------------------------------------------------------------------------ phases
def phase_rows(episodes: Sequence[Episode]) -> list[dict[str, Any]]:
    """The ``phases`` table: per executive, set and phase (see the module docstring)."""
    rows = []
    for (executive, scenario), group in sorted(_groups(episodes).items()):
        by_phase: dict[str, list[tuple[Episode, Mapping[str, Any]]]] = {}
        for episode in group:
            for entry in episode.figures["phases"]:
                if entry["phase"] != "-":  # not a phase: before the first tick, after the last
                    by_phase.setdefault(entry["phase"], []).append((episode, entry))
        for phase, entries in by_phase.items():
            count = len(group)
            causes: dict[str, float] = {}
            for _, entry in entries:
                for cause, points in entry["penalties_by_role"].items():
                    causes[cause] = causes.get(cause, 0.0) + points
            over = [ratio for ratio in (_time_over(episode, entry) for episode, entry in entries)
                    if ratio is not None]
            shares = [share for share in (_bound_share(episode, entry)
                                          for episode, entry in entries) if share is not None]
            rows.append({
                "executive": executive, "scenario": scenario, "phase": phase,
                "episodes": count, "reached": len(entries),
                "succeeded": sum(bool(entry.get("succeeded")) for _, entry in entries),
                "sim_time_s": _r(sum(entry["sim_time_s"] for _, entry in entries) / count),
                "bound_share": _r(statistics.fmean(shares)) if shares else None,
                "time_over_bound_median": _r(statistics.median(over)) if over else None,
                "points": _r(sum(entry["points"] for _, entry in entries) / count),
                **{f"points {cause}": _r(points / count) for cause, points in sorted(
                    causes.items())},
                **_zones(episode.figures.get("proxemics", {}).get(phase, {})
                         for episode, _ in entries),
            })
    return rows


def _legs(episode: Episode) -> dict[str, float]:
    return {str(leg["checkpoint"]): float(leg["bound_s"])
            for leg in episode.row.get("kinematic_bound_legs") or []}


def _phase_bound(episode: Episode, entry: Mapping[str, Any]) -> float | None:
    legs = _legs(episode)
    if not legs or not entry.get("checkpoints"):
        return None
    return sum(legs.get(mark["name"], 0.0) for mark in entry["checkpoints"])


def _time_over(episode: Episode, entry: Mapping[str, Any]) -> float | None:
    bound = _phase_bound(episode, entry)
    return entry["sim_time_s"] / bound if bound else None


def _bound_share(episode: Episode, entry: Mapping[str, Any]) -> float | None:
    bound, total = _phase_bound(episode, entry), sum(_legs(episode).values())
    return bound / total if bound is not None and total else None


def _zones(per_episode: Iterable[Mapping[str, Any]]) -> dict[str, float | None]:
    """Time-weighted zone shares over the episodes, guest and others apart."""
    seconds: dict[str, float] = {}
    totals: dict[str, float] = {}
    for people in per_episode:
        for who, zones in people.items():
            covered = float(zones.get("seconds", 0.0))
            totals[who] = totals.get(who, 0.0) + covered
            for zone, share in zones.items():
                if zone != "seconds":
                    name = f"{who} {zone}"
                    seconds[name] = seconds.get(name, 0.0) + share * covered
    return {name: _r(value / totals[name.split(" ", 1)[0]]) if totals[name.split(" ", 1)[0]]
            else None for name, value in sorted(seconds.items())}


def cause_rows(episodes: Sequence[Episode]) -> list[dict[str, Any]]:
    """Points per episode by penalty and what it was near, per executive and set."""
    rows = []
    for (executive, scenario), group in sorted(_groups(episodes).items()):
        causes: dict[str, float] = {}
        for episode in group:
            for cause, points in episode.figures["penalties"]["by_role"].items():
                causes[cause] = causes.get(cause, 0.0) + points
        total = sum(causes.values())
        for cause, points in sorted(causes.items(), key=lambda item: -item[1]):
            rows.append({"executive": executive, "scenario": scenario, "cause": cause,
                         "episodes": len(group), "points_per_episode": _r(points / len(group)),
                         "share": _r(points / total) if total else None})
    return rows


def situation_rows(episodes: Sequence[Episode]) -> list[dict[str, Any]]:
    """Points per episode by penalty and what the person near was doing
    (:mod:`bt_servicesim.records.situations`), with the robot moving and standing, per executive
    and set. A profile written before situations were kept adds nothing."""
    rows = []
    for (executive, scenario), group in sorted(_groups(episodes).items()):
        moving: dict[str, float] = {}
        standing: dict[str, float] = {}
        for episode in group:
            for situation, split in episode.figures["penalties"].get("by_situation", {}).items():
                moving[situation] = moving.get(situation, 0.0) + split.get(ROBOT_MOVING, 0.0)
                standing[situation] = standing.get(situation, 0.0) + split.get(ROBOT_STANDING, 0.0)
        total = sum(moving.values()) + sum(standing.values())
        for situation in sorted(moving, key=lambda key: -(moving[key] + standing[key])):
            points = moving[situation] + standing[situation]
            rows.append({"executive": executive, "scenario": scenario, "situation": situation,
                         "episodes": len(group), "points_per_episode": _r(points / len(group)),
                         "robot_moving_per_episode": _r(moving[situation] / len(group)),
                         "robot_standing_per_episode": _r(standing[situation] / len(group)),
                         "share": _r(points / total) if total else None})
    return rows


# ------------------------------------------------------------------------------------ triage
def triage_groups(episodes: Sequence[Episode]) -> list[dict[str, Any]]:
    """Failed episodes grouped by phase reached, node that failed last and reason."""
    groups: dict[tuple[str, str, str, str, str], list[Episode]] = {}
    for episode in episodes:
        if episode.row.get("completed"):
            continue
        phase, node, reason = _where_it_failed(episode)
        groups.setdefault((*episode.group, phase, node, reason), []).append(episode)
    result = []
    for (executive, scenario, phase, node, reason), group in sorted(
            groups.items(), key=lambda item: (-len(item[1]), item[0])):
        first = group[0]
        result.append({
            "executive": executive, "scenario": scenario, "phase": phase, "node": node,
            "reason": reason, "count": len(group),
            "seeds": sorted({episode.row.get("episode_seed") for episode in group},
                            key=lambda seed: (seed is None, seed or 0)),
            "run": first.row.get("reproduce"),
            "replay": _replay_command(first, phase),
        })
    return result


def _where_it_failed(episode: Episode) -> tuple[str, str, str]:
    """(phase reached, last node that failed, reason): the reason is the node's feedback with
    its numbers as ``#``, so that one cause groups; the run's own failure if there is no log."""
    profile = episode.profile
    failure = str(episode.row.get("failure") or "did not complete")
    if profile is None:
        return "-", "-", failure
    reached = [entry["phase"] for entry in profile["phases"] if entry["phase"] != "-"]
    phase = reached[-1] if reached else "-"
    last = profile.get("last_failure")
    if last is None:
        return phase, "-", failure
    return phase, str(last["node"]).rsplit(".", 1)[-1], NUMBER.sub("#", str(last["reason"]))


def _replay_command(episode: Episode, phase: str) -> str | None:
    if episode.profile is None or not episode.row.get("out"):
        return None
    tick = next((entry.get("last_failure_tick") for entry in episode.profile["phases"]
                 if entry["phase"] == phase), None)
    moment = f" --tick {tick}" if tick else ""
    return f"python -m bt_servicesim.replay {episode.row['out']}{moment}"


# --------------------------------------------------------------------------------- tree diff
def tree_diff_rows(nodes: Sequence[Mapping[str, Any]], executives: Sequence[str], *,
                   top: int = DIFF_TOP) -> list[dict[str, Any]]:
    """For every pair of executives and each set: the shared nodes whose figures changed most
    (by the largest change of any of :data:`DIFF_MEASURES`, each scaled by its largest value
    over the pair), with both figures."""
    table = {(row["executive"], row["scenario"], row["node"]): row for row in nodes}
    scenarios = sorted({row["scenario"] for row in nodes})
    rows = []
    for first, second in combinations(executives, 2):
        for scenario in scenarios:
            shared = [key for (executive, set_, key) in table
                      if executive == first and set_ == scenario
                      and (second, scenario, key) in table]
            changes = []
            for key in shared:
                a, b = table[(first, scenario, key)], table[(second, scenario, key)]
                change = {measure: _change(a.get(measure), b.get(measure))
                          for measure in DIFF_MEASURES}
                score = max(abs(value) for value in change.values())
                if score > 0:
                    changes.append((score, key, a, b))
            for score, key, a, b in sorted(changes, key=lambda item: (-item[0], item[1]))[:top]:
                rows.append({"first": first, "second": second, "scenario": scenario,
                             "node": key, "label": a["label"], "change": _r(score),
                             **{f"{measure} {name}": row.get(measure)
                                for measure in DIFF_MEASURES
                                for name, row in ((first, a), (second, b))}})
    return rows


def _change(a: float | None, b: float | None) -> float:
    """``b - a`` over the larger of the two (0 when both are 0 or missing)."""
    a, b = a or 0.0, b or 0.0
    scale = max(abs(a), abs(b))
    return (b - a) / scale if scale else 0.0


# ------------------------------------------------------------------------------------ output
def profile_tables(rows: Iterable[Mapping[str, Any]], executives: Sequence[str]
                   ) -> dict[str, list[dict[str, Any]]]:
    """Every table, from the rows of an evaluation (their profiles read from their runs)."""
    episodes = load_episodes(rows)
    nodes = node_rows(episodes)
    return {"nodes": nodes, "recoveries": recovery_rows(episodes), "phases": phase_rows(episodes),
            "causes": cause_rows(episodes), "situations": situation_rows(episodes),
            "triage": triage_groups(episodes),
            "tree_diff": tree_diff_rows(nodes, executives)}


def write_profile_tables(directory: Path, tables: Mapping[str, list[dict[str, Any]]]) -> None:
    """``profiles.json`` (every table) and one ``profile_<table>.csv`` per table."""
    (directory / TABLES_NAME).write_text(json.dumps(tables, indent=1) + "\n")
    for name, table in tables.items():
        write_csv(directory / f"profile_{name}.csv", table)


def write_csv(path: Path, table: Sequence[Mapping[str, Any]]) -> None:
    columns = list(dict.fromkeys(column for row in table for column in row))
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.DictWriter(stream, fieldnames=columns)
        writer.writeheader()
        for row in table:
            writer.writerow({key: json.dumps(value) if isinstance(value, list) else value
                             for key, value in row.items()})


def read_node_table(directory: Path) -> list[dict[str, Any]]:
    """The ``nodes`` table of an evaluation directory; ``ValueError`` naming what is wrong."""
    path = directory / TABLES_NAME
    try:
        return list(json.loads(path.read_text())["nodes"])
    except OSError as error:
        raise ValueError(f"{path}: {error.strerror or error} (an evaluation writes it)") \
            from error
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(f"{path}: not an evaluation's profile tables ({error})") from error


def _r(value: float) -> float:
    return round(value, 4)
