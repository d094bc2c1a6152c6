"""One episode as the HTML report shows it: its facts, its timeline and the commands for it.

Design intent: the page is drawn in the browser from plain data, so this module turns a run
directory (``report.json``, ``tree_log.jsonl``, ``profile.json`` when the run wrote one,
``trajectory.png`` when it was drawn) into one small JSON-ready dict, and never reads the
recording (``run.mcap``: megabytes per episode, an evaluation has hundreds).

The timeline has up to four lanes over the task's sim time:

``legs``
    the referee's checkpoints, each from the end of the one before to its own booking, with the
    leg's kinematic bound when the evaluation computed one: the phases as the referee counts
    them, for every executive;
``phases``
    the tree's own phases (the children of the composite the tree log's header names), when the
    tree log says which composite that is;
``leaves``
    the running leaf (the tip) from tick to tick: stretches ``[start, end, index]`` into
    ``names``;
``bookings``
    the points the referee booked and when, ``[sim time, cause, points]``, from the run's
    profile (:mod:`bt_servicesim.records.profile`'s ``timeline``).

The tree lanes come from the profile's ``timeline`` (its segments), or for a run recorded
without a profile from the tree log, scanned for the two fields a lane needs (sim time and tip)
without decoding each line's node states: a mission's log is megabytes, and an evaluation's
page reads hundreds. A lane that cannot be drawn carries the reason instead (``why``), so the
page can say so.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from bt_servicesim.records.profile import PROFILE_NAME
from bt_servicesim.records.tree_log import LOG_NAME

PICTURE_NAME, RECORDING_NAME = "trajectory.png", "run.mcap"
"""The picture and the recording as a run names them (:mod:`bt_servicesim.records.trajectory`,
:mod:`bt_servicesim.records.mcap`), named again here: the page's modules import no ROS, so that
an evaluation's page is written without it."""
_TIME_FIELD, _TIP_FIELD, _NODES_FIELD = b'"sim_time_s": ', b'"tip": ', b', "nodes": '


def episode_view(run_dir: Path, report: Mapping[str, Any], *, link_base: Path) -> dict[str, Any]:
    """The episode in ``run_dir`` as the page shows it; links are relative to ``link_base``
    (the directory the page is written in)."""
    profile = read_json(run_dir / PROFILE_NAME)
    link = _relative(run_dir, link_base)
    return {
        "dir": link,
        "executive": report.get("executive"),
        "scenario": report.get("scenario"),
        "episode": report.get("episode"),
        "seed": report.get("episode_seed", report.get("seed")),
        "status": report.get("status"),
        "completed": bool(report.get("completed")),
        "score": _number(report.get("score")),
        "sim_time_s": _number(report.get("sim_time_s")),
        "over_bound": _number(report.get("time_over_bound")),
        "bound_s": _number(report.get("kinematic_bound_s")),
        "failure": report.get("failure"),
        "last_activity": report.get("last_activity"),
        "penalties": {str(kind): _number(points)
                      for kind, points in (report.get("penalties") or {}).items()},
        "causes": _causes(profile),
        "picture": f"{link}/{PICTURE_NAME}" if (run_dir / PICTURE_NAME).is_file() else None,
        "timeline": timeline(run_dir, report, profile),
        "commands": commands(run_dir, report),
    }


def read_json(path: Path) -> dict[str, Any] | None:
    """A JSON object from ``path``, or None when it is missing or not one."""
    try:
        value = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return value if isinstance(value, dict) else None


def _relative(run_dir: Path, base: Path) -> str:
    try:
        return run_dir.resolve().relative_to(base.resolve()).as_posix() or "."
    except ValueError:
        return run_dir.resolve().as_uri()


def _number(value: Any) -> float | None:
    return None if value is None else round(float(value), 3)


def _causes(profile: Mapping[str, Any] | None) -> dict[str, float] | None:
    """Points by penalty and by what it was near (the profile's ``by_role``), if profiled."""
    if profile is None:
        return None
    penalties = profile.get("penalties") or {}
    return {str(cause): round(float(points), 3)
            for cause, points in (penalties.get("by_role") or {}).items()}


# ------------------------------------------------------------------------------------ commands
def commands(run_dir: Path, report: Mapping[str, Any]) -> dict[str, str | None]:
    """What to type to play the episode again, step through its tree and open its recording."""
    replay = report.get("reproduce")
    key = report.get("episode_key") or {}
    if isinstance(replay, str):
        for argument in key.get("sim_args") or ():
            if str(argument) not in replay:
                replay += f" --sim-arg={argument}"
    recording = run_dir / RECORDING_NAME
    return {
        "replay": replay if isinstance(replay, str) else None,
        "step": (f"python -m bt_servicesim.replay {run_dir.resolve()} --step"
                 if (run_dir / LOG_NAME).is_file() else None),
        "recording": str(recording.resolve()) if recording.is_file() else None,
    }


# ------------------------------------------------------------------------------------ timeline
def timeline(run_dir: Path, report: Mapping[str, Any],
             profile: Mapping[str, Any] | None) -> dict[str, Any]:
    """The episode's lanes over sim time (see the module docstring): from the profile's
    ``timeline`` when the run has one, else the tip from the tree log."""
    legs = checkpoint_legs(report)
    kept = (profile or {}).get("timeline")
    if isinstance(kept, dict):
        names, leaves, phases = profiled_stretches(kept.get("segments") or [])
        why = None
    else:
        names, leaves, phases, why = tip_stretches(run_dir / LOG_NAME, report)
    bookings = kept.get("bookings") if isinstance(kept, dict) else None
    end = max([float(report.get("sim_time_s") or 0.0)]
              + [stretch[1] for stretch in leaves] + [leg[1] for leg in legs])
    return {
        "end": round(end, 3),
        "legs": legs,
        "phases": phases,
        "leaves": leaves,
        "names": names,
        "why_no_leaves": why,
        "bookings": bookings if isinstance(bookings, list) else None,
        "why_no_bookings": (None if isinstance(bookings, list) else
                            "the run has no profile.json (a run of a tree writes one)"
                            if profile is None else
                            "the run's profile.json is older than the times of its bookings"),
    }


def profiled_stretches(segments: list[list[Any]]
                       ) -> tuple[list[str], list[list[Any]], list[list[Any]] | None]:
    """The leaves' keys, the tip's stretches and the phases' stretches from the profile's
    segments (``[start, end, tip, phase]``)."""
    names: dict[str, int] = {}
    leaves: list[list[Any]] = []
    phases: list[list[Any]] = []
    for start, end, tip, phase in segments:
        if tip is not None:
            leaves.append([start, end, names.setdefault(str(tip), len(names))])
        if phases and phases[-1][2] == phase and phases[-1][1] == start:
            phases[-1][1] = end
        else:
            phases.append([start, end, phase])
    named = [stretch for stretch in phases if stretch[2] != "-"]
    return list(names), leaves, phases if named else None


def checkpoint_legs(report: Mapping[str, Any]) -> list[list[Any]]:
    """``[start, end, checkpoint, bound_s]`` for each checkpoint the referee booked: its own
    time (report.json's ``sim_time_s`` per checkpoint) after the one before; the bound from the
    evaluation's kinematic legs, when there are any."""
    bounds = {str(leg.get("checkpoint")): leg.get("bound_s")
              for leg in report.get("kinematic_bound_legs") or () if isinstance(leg, dict)}
    legs, start = [], 0.0
    for checkpoint in report.get("checkpoints") or ():
        if not checkpoint.get("done"):
            break
        end = start + float(checkpoint.get("sim_time_s") or 0.0)
        name = str(checkpoint.get("name"))
        legs.append([round(start, 3), round(end, 3), name, bounds.get(name)])
        start = end
    return legs


def tip_stretches(log: Path, report: Mapping[str, Any]
                  ) -> tuple[list[str], list[list[Any]], list[list[Any]] | None, str | None]:
    """From the tree log: the leaves' keys, the tip's stretches ``[start, end, index]``, the
    phases' stretches ``[start, end, phase]`` (None when the log names no phases' composite)
    and, when there is no log to read, why."""
    try:
        with log.open("rb") as stream:
            header = json.loads(stream.readline() or b"{}")
            times, tips = _scan(stream)
    except FileNotFoundError:
        executive = report.get("executive")
        return [], [], None, ("the baseline executive is not a tree: it logs no running leaf"
                              if executive == "baseline" else f"no {LOG_NAME} in the run")
    except (OSError, ValueError) as error:
        return [], [], None, f"{LOG_NAME} cannot be read: {error}"
    end = float(report.get("sim_time_s") or (times[-1] if times else 0.0))
    names: dict[str, int] = {}
    stretches: list[list[Any]] = []
    for number, (time, tip) in enumerate(zip(times, tips, strict=True)):
        until = times[number + 1] if number + 1 < len(times) else max(end, time)
        if tip is None or until <= time:
            continue
        index = names.setdefault(tip, len(names))
        if stretches and stretches[-1][2] == index and stretches[-1][1] == time:
            stretches[-1][1] = round(until, 3)
        else:
            stretches.append([round(time, 3), round(until, 3), index])
    keys = list(names)
    return keys, stretches, _phase_stretches(header, keys, stretches), None


def _scan(stream: Any) -> tuple[list[float], list[str | None]]:
    """Sim time and tip of every tick line, read by position (see the module docstring)."""
    times: list[float] = []
    tips: list[str | None] = []
    last: str | None = None
    for line in stream:
        start = line.find(_TIME_FIELD)
        tip_at = line.find(_TIP_FIELD)
        if start < 0 or tip_at < 0:
            continue
        start += len(_TIME_FIELD)
        time = float(line[start:line.index(b",", start)])
        tip_at += len(_TIP_FIELD)
        text = line[tip_at:line.find(_NODES_FIELD, tip_at)]
        tip = None if text == b"null" else json.loads(text)
        if tips and tip == last:
            continue
        times.append(time)
        tips.append(tip)
        last = tip
    return times, tips


def _phase_stretches(header: Mapping[str, Any], keys: list[str],
                     stretches: list[list[Any]]) -> list[list[Any]] | None:
    """The tree's phases over time: each tip's phase is the name after the phases'
    composite's key in its own key (decorators over a phase are looked through)."""
    composite = header.get("phases")
    nodes = header.get("nodes") or []
    if not composite:
        return None
    prefix = next((str(node["key"]) + "." for node in nodes
                   if node.get("label") == composite and node.get("kind") != "behaviour"), None)
    if prefix is None:
        return None
    decorators = {str(node["key"]) for node in nodes if node.get("kind") == "decorator"}
    phase_of = [_phase(key, prefix, decorators) for key in keys]
    phases: list[list[Any]] = []
    for start, end, index in stretches:
        phase = phase_of[index]
        if phases and phases[-1][2] == phase and phases[-1][1] == start:
            phases[-1][1] = end
        else:
            phases.append([start, end, phase])
    return phases


def _phase(key: str, prefix: str, decorators: set[str]) -> str:
    if not key.startswith(prefix):
        return "-"
    parts = key[len(prefix):].split(".")
    path = prefix[:-1]
    for part in parts:
        path = f"{path}.{part}"
        if path not in decorators:
            return part
    return parts[0]
