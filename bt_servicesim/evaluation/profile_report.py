"""The profile tables in ``results.md``: where the points and time went, why missions failed.

The tables themselves (:mod:`bt_servicesim.evaluation.node_tables`) are written whole as CSV and
JSON beside ``results.md``; this draws the parts a reader looks at first. Every measure is
defined in ``docs/reference/profiles.md``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

TOP_NODES = 8


def profile_sections(tables: Mapping[str, list[dict[str, Any]]],
                     executives: Sequence[str]) -> list[str]:
    if not tables.get("nodes"):
        return ["## Where the points and the time went", "",
                "No episode left a profile (profile.json: behaviour-tree executives only).", ""]
    lines = ["## Where the points and the time went", "",
             "From every episode's profile.json (definitions: "
             "[reference/profiles.md](reference/profiles.md)); the whole tables are "
             "`profile_*.csv` and `profiles.json` in the evaluation directory, and "
             "`python -m bt_servicesim.dump --heat DIR --measure points_under` draws them on "
             "the tree.", "", "### Points by cause (per episode)", "",
             "| executive | set | cause | points | share |", "|---|---|---|---|---|"]
    lines += [f"| {row['executive']} | {row['scenario']} | {row['cause']} | "
              f"{row['points_per_episode']:.1f} | {_percent(row['share'])} |"
              for row in tables["causes"]]
    if tables.get("situations"):
        lines += ["", "### Points by situation (per episode)", "",
                  "What the person near was doing, and the robot: a walker stands while anyone "
                  "is in its lane, so points beside a walker standing for the robot are points "
                  "the robot holds where they are.", "",
                  "| executive | set | situation | points | robot moving | robot standing | "
                  "share |", "|---|---|---|---|---|---|---|"]
        lines += [f"| {row['executive']} | {row['scenario']} | {row['situation']} | "
                  f"{row['points_per_episode']:.1f} | {row['robot_moving_per_episode']:.1f} | "
                  f"{row['robot_standing_per_episode']:.1f} | {_percent(row['share'])} |"
                  for row in tables["situations"]]
    lines += ["", "### Phases (per episode)", "",
              "| executive | set | phase | reached | succeeded | sim s | bound share | "
              "time over bound (median) | points | guest intimate / personal | others "
              "intimate / personal |", "|" + "---|" * 11]
    lines += [_phase_line(row) for row in tables["phases"]]
    lines += ["", "### The nodes that cost most points", "",
              "| executive | set | node | phase | ran in | starts / episode | failure rate | "
              "time share | points as tip / episode |", "|" + "---|" * 9]
    lines += [_node_line(row) for row in _costliest(tables["nodes"])]
    lines += ["", "### Recoveries and retries", "",
              "| executive | set | phase | node | fired in | fired / episode | phase succeeded "
              "after |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {row['executive']} | {row['scenario']} | {row['phase']} | {_path(row['node'])} | "
              f"{_percent(row['fired_share'])} | {row['fired_per_episode']:.2f} | "
              f"{_percent(row['phase_succeeded_after'])} |"
              for row in tables["recoveries"] if row["fired_share"] > 0]
    lines += ["", *triage_lines(tables["triage"]), ""]
    if len(executives) > 1 and tables.get("tree_diff"):
        lines += [*diff_lines(tables["tree_diff"]), ""]
    return lines


def _phase_line(row: Mapping[str, Any]) -> str:
    return (f"| {row['executive']} | {row['scenario']} | {row['phase']} | {row['reached']} | "
            f"{row['succeeded']} | {row['sim_time_s']:.1f} | {_percent(row['bound_share'])} | "
            f"{_ratio(row['time_over_bound_median'])} | {row['points']:.1f} | "
            f"{_percent(row.get('guest intimate'))} / {_percent(row.get('guest personal'))} | "
            f"{_percent(row.get('others intimate'))} / {_percent(row.get('others personal'))} |")


def _costliest(nodes: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in nodes:
        if row["points_tip"] > 0:
            groups.setdefault((row["executive"], row["scenario"]), []).append(row)
    return [row for _, group in sorted(groups.items())
            for row in sorted(group, key=lambda row: -row["points_tip"])[:TOP_NODES]]


def _node_line(row: Mapping[str, Any]) -> str:
    return (f"| {row['executive']} | {row['scenario']} | {_path(row['node'])} | {row['phase']} | "
            f"{_percent(row['ran_share'])} | {row['starts_per_episode']:.2f} | "
            f"{_percent(row['failure_rate'])} | {_percent(row['time_share'])} | "
            f"{row['points_tip']:.1f} |")


def triage_lines(groups: Sequence[Mapping[str, Any]]) -> list[str]:
    lines = ["### Failure triage", ""]
    if not groups:
        return [*lines, "No episode failed."]
    lines += ["Failed episodes grouped by the phase they reached, the node that failed last and "
              "its feedback (numbers as #); `run` plays the group's first episode again, "
              "`replay` shows its tree when the phase's last attempt failed.", "",
              "| executive | set | episodes | phase | last failed node | reason | seeds | "
              "commands |", "|" + "---|" * 8]
    for group in groups:
        seeds = ", ".join("shipped" if seed is None else str(seed) for seed in group["seeds"])
        commands = " <br> ".join(f"`{command}`" for command in (group["run"], group["replay"])
                                 if command)
        lines.append(f"| {group['executive']} | {group['scenario']} | {group['count']} | "
                     f"{group['phase']} | {group['node']} | {_cell(group['reason'])} | "
                     f"{seeds} | {commands} |")
    return lines


def diff_lines(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    lines = ["### Tree against tree: the shared nodes that changed most", "",
             "| pair | set | node | change | ran in | starts / episode | failure rate | "
             "sim s running / episode | points under / episode |", "|" + "---|" * 9]
    for row in rows:
        first, second = row["first"], row["second"]

        def both(measure: str, show: Any, first: str = first, second: str = second,
                 row: Mapping[str, Any] = row) -> str:
            return f"{show(row[f'{measure} {first}'])} → {show(row[f'{measure} {second}'])}"

        lines.append(
            f"| {first} → {second} | {row['scenario']} | {_path(row['node'])} | "
            f"{row['change']:+.2f} | {both('ran_share', _percent)} | "
            f"{both('starts_per_episode', _number)} | {both('failure_rate', _percent)} | "
            f"{both('running_s', _number)} | {both('points_under', _number)} |")
    return lines


def _path(key: str) -> str:
    """The last three parts of a node's path: enough to find it, short enough to read."""
    return ".".join(key.split(".")[-3:])


def _percent(value: float | None) -> str:
    return "–" if value is None else f"{value:.0%}"


def _ratio(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


def _number(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


def _cell(text: str) -> str:
    return text.replace("|", "/")
