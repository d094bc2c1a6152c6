"""A mission's profile (``profile.json``): where its sim time went and where its points were lost.

Design intent: an evaluation reports outcomes (success, score, time); the profile says *why*.
It is built after the run from its records only, so any recorded run can be profiled again
(``python -m bt_servicesim.profile DIR``), and it is a pure function of plain inputs, free of
ROS (the reader of ``run.mcap`` is :mod:`bt_servicesim.records.profile_inputs`):

* the tree's snapshot log (:class:`~bt_servicesim.records.tree_log.TickRecord` lines), which
  gives every node's status changes and the tip, tick by tick, and so the phase;
* the referee's running sums of points by cause (:class:`Booking`, cumulative, e.g.
  ``approximation/walker/human_3``: the simulator books every penalty with what it was near);
* the distance from the robot to the guest and to the nearest other person (:class:`Proximity`);
* the checkpoints as the referee booked them (:class:`CheckpointMark`).

Points booked between two samples are spread over the moments between them in proportion to
time, and each share goes to the tip (the running leaf) and the phase of that moment: "which
behaviour was running when the points were lost". A node's figures, keyed by its path in the
tree (the snapshot log's key, which carries no random UUID):

``ticks``, ``starts``, ``success``, ``failure``
    how often it was ticked, began (ticked when not RUNNING), succeeded and failed: the log's
    counts line (:class:`~bt_servicesim.records.tree_log.TickCounter`, exact). A log without
    one (cut short) gives what its changes show: a node that ran and finished the same way
    again between two lines is then not seen;
``invalid``
    how often it was stopped from above while RUNNING (preempted, halted).
``running_s``, ``tip_s``
    sim seconds it was RUNNING; sim seconds it was the tip.
``points_tip``, ``points_under``
    points booked while it was the tip; while the tip was it or under it (inclusive).
``fired`` (a ``Retry`` or a ``RecoveryNode`` only)
    how often it went round again: a retry's child failures it did not pass on; a recovery
    node's recovery starts (its second child's).

The profile's ``timeline`` keeps the moments these figures are summed from, for a page to draw
over sim time: ``segments``, ``[start, end, tip, phase]`` for each stretch with one tip, and
``bookings``, ``[sim time, cause, points]`` for the points booked between two samples (by
penalty and what it was near, as ``by_role``), at the later sample's time.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from py_trees.common import Status

from bt_servicesim.records.situations import PeopleSample, situation_points
from bt_servicesim.records.tree_log import TickRecord
from bt_servicesim.tree.shape import TreeShape

PROFILE_NAME = "profile.json"
PROFILE_VERSION = 1
NO_PHASE = "-"
ZONES = (("intimate", 0.45), ("personal", 1.2), ("social", 3.6), ("public", float("inf")))
"""Hall's proxemic zones as social-navigation benchmarks use them (HuNavSim's evaluator):
upper bounds in metres of the distance between the robot's and the person's centres."""
CAUSE_SEPARATOR = "/"
CHECKPOINT_LAG_S = 0.25
"""A checkpoint belongs to the phase running this long before the referee's state that booked
it was recorded: the referee books a call's checkpoint as it answers, and the tree moves to its
next phase at the tick that takes the answer, before that state reaches the records."""


@dataclass(frozen=True)
class Booking:
    """The referee's running sums at one moment: cause key -> points booked so far.

    A cause key is ``penalty/role/name`` (``approximation/walker/human_3``), ``penalty/walls``
    or ``penalty/objects``; a backend that does not attribute books ``penalty/unattributed``.
    """

    sim_time_s: float
    sums: Mapping[str, float]


@dataclass(frozen=True)
class Proximity:
    """Distances from the robot's centre at one moment (None: nobody of that kind)."""

    sim_time_s: float
    guest_m: float | None
    others_m: float | None


@dataclass(frozen=True)
class CheckpointMark:
    """A checkpoint the referee booked: when (sim time) and its own time (task sim s)."""

    name: str
    sim_time_s: float
    duration_s: float


@dataclass
class NodeFigures:
    """One node's figures in one episode (see the module docstring)."""

    ticks: int = 0
    starts: int = 0
    success: int = 0
    failure: int = 0
    invalid: int = 0
    running_s: float = 0.0
    tip_s: float = 0.0
    points_tip: float = 0.0
    points_under: float = 0.0
    last_failure_tick: int | None = None
    last_failure_reason: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {"ticks": self.ticks, "starts": self.starts, "success": self.success,
                "failure": self.failure, "invalid": self.invalid,
                "running_s": round(self.running_s, 3), "tip_s": round(self.tip_s, 3),
                "points_tip": round(self.points_tip, 3),
                "points_under": round(self.points_under, 3)}


@dataclass(frozen=True)
class Segment:
    """A stretch of sim time with one tip (and so one phase)."""

    start_s: float
    end_s: float
    tip: str | None
    phase: str


# ------------------------------------------------------------------------------ node statistics
@dataclass
class _Running:
    since_s: float
    since_tick: int


@dataclass
class NodeCounter:
    """Walks the tick records once: every node's counts and RUNNING time, and the segments."""

    shape: TreeShape
    phases: str | None
    figures: dict[str, NodeFigures] = field(default_factory=dict)
    segments: list[Segment] = field(default_factory=list)
    last_failure: tuple[int, float, str, str] | None = None
    """(tick, sim time, key, feedback) of the last leaf that failed."""

    def __post_init__(self) -> None:
        self.figures = {key: NodeFigures() for key in self.shape.keys}
        self._states: dict[str, tuple[Status, str]] = {}
        self._running: dict[str, _Running] = {}
        self._phase_of = phase_map(self.shape, self.phases)
        self._leaves = {node.key for node in self.shape.nodes if node.kind == "behaviour"}
        self._telling = telling_failures(self.shape)
        self.phase_failures: dict[str, int] = {}
        """The tick of the last telling failure (see :func:`telling_failures`) per phase."""
        self._tip: str | None = None
        self._tip_since: float | None = None

    def add(self, record: TickRecord) -> None:
        now, tick = record.sim_time_s, record.tick
        for key, (status, feedback) in record.nodes.items():
            if key in self.figures:
                self._change(key, status, feedback, now=now, tick=tick)
        if self._tip_since is not None and (record.tip != self._tip):
            self._close_segment(now)
        if self._tip_since is None or record.tip != self._tip:
            self._tip, self._tip_since = record.tip, now

    def _change(self, key: str, status: Status, feedback: str, *, now: float, tick: int) -> None:
        previous = self._states.get(key, (Status.INVALID, ""))[0]
        self._states[key] = (status, feedback)
        figures = self.figures[key]
        if status == Status.RUNNING:
            if previous != Status.RUNNING:
                figures.starts += 1
                self._running[key] = _Running(since_s=now, since_tick=tick)
            return  # still running: only its feedback changed
        running = self._running.pop(key, None)
        if running is not None:
            figures.running_s += now - running.since_s
            figures.ticks += tick - running.since_tick
        if status == Status.INVALID:
            figures.invalid += previous == Status.RUNNING
            return
        if previous != Status.RUNNING:
            figures.starts += 1  # finished within the tick it began
        figures.ticks += 1
        if status == Status.SUCCESS:
            figures.success += 1
        else:
            figures.failure += 1
            figures.last_failure_tick, figures.last_failure_reason = tick, feedback
            if key in self._telling:
                self.phase_failures[self._phase_of.get(key, NO_PHASE)] = tick
                if key in self._leaves:
                    self.last_failure = (tick, now, key, feedback)

    def _close_segment(self, now: float) -> None:
        assert self._tip_since is not None
        if now > self._tip_since:
            self.segments.append(Segment(start_s=self._tip_since, end_s=now, tip=self._tip,
                                         phase=self._phase_of.get(self._tip or "", NO_PHASE)))

    def finish(self, *, end_s: float, end_tick: int) -> None:
        """Close what still runs at ``end_s`` (the last sim time the run saw)."""
        for key, running in self._running.items():
            figures = self.figures[key]
            figures.running_s += max(0.0, end_s - running.since_s)
            figures.ticks += max(0, end_tick - running.since_tick + 1)
        self._running.clear()
        if self._tip_since is not None:
            self._close_segment(max(end_s, self._tip_since))
            self._tip_since = None
        for segment in self.segments:
            if segment.tip in self.figures:
                self.figures[segment.tip].tip_s += segment.end_s - segment.start_s

    def phase_at(self, sim_time_s: float) -> str:
        """The phase at ``sim_time_s`` (that of the segment it falls in)."""
        starts = [segment.start_s for segment in self.segments]
        index = bisect.bisect_right(starts, sim_time_s) - 1
        return self.segments[index].phase if index >= 0 else NO_PHASE


QUIET_FAILURES = frozenset({"FailureIsRunning", "FailureIsSuccess", "Inverter"})
"""Decorators under which a child's failure is the normal course (a watch, an optional step)."""


def telling_failures(shape: TreeShape) -> set[str]:
    """The nodes whose failure means something went wrong: a failure climbs through sequences
    and parallels, and is the normal course when it reaches a fallback (failing over is what a
    fallback is for) or a decorator in :data:`QUIET_FAILURES` (a watch, an optional step)."""
    nodes = shape.nodes
    telling = set()
    for node in nodes:
        parent = node.parent
        while parent is not None and nodes[parent].kind in ("sequence", "parallel"):
            parent = nodes[parent].parent
        if parent is None or not (nodes[parent].kind == "selector"
                                  or nodes[parent].type in QUIET_FAILURES):
            telling.add(node.key)
    return telling


def phase_map(shape: TreeShape, phases: str | None) -> dict[str, str]:
    """Each node's phase: the child of the ``phases`` composite it is under, named as the
    executive names it (a subtree by its ``<SubTree name>``, decorators looked through)."""
    named = _phase_heads(shape, phases)
    result: dict[str, str] = {}
    for index, node in enumerate(shape.nodes):
        for head, phase in named.items():
            if head in _ancestors(shape, index):
                result[node.key] = phase
    return result


def phase_nodes(shape: TreeShape, phases: str | None) -> dict[str, str]:
    """Each phase's own node (the first under the phases' composite that is not a decorator:
    what fails when an attempt at the phase fails), by phase name."""
    heads = _phase_heads(shape, phases)
    return {phase: shape.nodes[_named(shape, head)].key for head, phase in heads.items()}


def _phase_heads(shape: TreeShape, phases: str | None) -> dict[int, str]:
    """The phases' composite's children (their indices), with their phase names."""
    nodes = shape.nodes
    composites = [index for index, node in enumerate(nodes)
                  if phases is not None and node.label == phases and node.kind != "behaviour"]
    if not composites:
        return {}
    top = composites[0]
    heads: dict[int, str] = {}
    for index, node in enumerate(nodes):
        if node.parent == top:
            named = _named(shape, index)
            parent_key = nodes[nodes[named].parent or 0].key
            heads[index] = nodes[named].key[len(parent_key) + 1:].split(".", 1)[0]
    return heads


def _named(shape: TreeShape, head: int) -> int:
    """The first node from ``head`` down its only children that is not a decorator."""
    index = head
    while shape.nodes[index].kind == "decorator":
        children = [position for position, node in enumerate(shape.nodes)
                    if node.parent == index]
        if not children:
            break
        index = children[0]
    return index


def _ancestors(shape: TreeShape, index: int) -> list[int]:
    """Root first, down to ``index`` itself."""
    path = [index]
    while (parent := shape.nodes[path[-1]].parent) is not None:
        path.append(parent)
    return path[::-1]


# ------------------------------------------------------------------------------------ points
def increments(bookings: Sequence[Booking]) -> list[tuple[float, float, dict[str, float]]]:
    """(from, to, points by cause booked in between), from the running sums."""
    result = []
    last: Mapping[str, float] = {}
    last_time: float | None = None
    for booking in bookings:
        change = {cause: value - last.get(cause, 0.0) for cause, value in booking.sums.items()
                  if value - last.get(cause, 0.0) > 1e-9}
        if change:
            start = booking.sim_time_s if last_time is None else last_time
            result.append((start, booking.sim_time_s, change))
        last, last_time = booking.sums, booking.sim_time_s
    return result


def spread(points: list[tuple[float, float, dict[str, float]]], segments: Sequence[Segment]
           ) -> list[tuple[Segment | None, dict[str, float]]]:
    """Each booking's points shared out over the segments its interval overlaps, by time; a
    booking outside every segment (before the first tick, after the last) goes to ``None``."""
    starts = [segment.start_s for segment in segments]
    shares: list[tuple[Segment | None, dict[str, float]]] = []
    for start, end, change in points:
        span = end - start
        first = max(0, bisect.bisect_right(starts, start) - 1)
        given = 0.0
        for segment in segments[first:]:
            if segment.start_s >= end and span > 0:
                break
            overlap = (min(end, segment.end_s) - max(start, segment.start_s)) if span > 0 else (
                1.0 if segment.start_s <= end <= segment.end_s else 0.0)
            if overlap <= 0:
                continue
            fraction = overlap / span if span > 0 else 1.0
            fraction = min(fraction, 1.0 - given)
            given += fraction
            shares.append((segment, {cause: value * fraction for cause, value in change.items()}))
            if span <= 0 or given >= 1.0 - 1e-12:
                break
        if given < 1.0 - 1e-9:
            shares.append((None, {cause: value * (1.0 - given)
                                  for cause, value in change.items()}))
    return shares


def by_role(causes: Mapping[str, float]) -> dict[str, float]:
    """``approximation/walker/human_3`` and ``approximation/walker/human_5`` as
    ``approximation/walker``: points by penalty and what it was near, names dropped."""
    grouped: dict[str, float] = {}
    for cause, value in causes.items():
        key = CAUSE_SEPARATOR.join(cause.split(CAUSE_SEPARATOR)[:2])
        grouped[key] = grouped.get(key, 0.0) + value
    return grouped


def _add(into: dict[str, float], change: Mapping[str, float]) -> None:
    for cause, value in change.items():
        into[cause] = into.get(cause, 0.0) + value


def _rounded(values: Mapping[str, float]) -> dict[str, float]:
    return {key: round(value, 3) for key, value in sorted(values.items())}


# ---------------------------------------------------------------------------------- proxemics
def zone_of(distance_m: float) -> str:
    return next(name for name, bound in ZONES if distance_m < bound)


def proxemics(samples: Sequence[Proximity], *, end_s: float, phase_at: Any
              ) -> dict[str, dict[str, dict[str, float]]]:
    """Per phase, for the guest and for the nearest other person, the share of the time the
    samples cover spent in each zone (a sample holds until the next one)."""
    seconds: dict[str, dict[str, dict[str, float]]] = {}
    for index, sample in enumerate(samples):
        until = samples[index + 1].sim_time_s if index + 1 < len(samples) else end_s
        duration = until - sample.sim_time_s
        if duration <= 0:
            continue
        phase = phase_at(sample.sim_time_s)
        for who, distance in (("guest", sample.guest_m), ("others", sample.others_m)):
            if distance is None:
                continue
            zones = seconds.setdefault(phase, {}).setdefault(who, {})
            zone = zone_of(distance)
            zones[zone] = zones.get(zone, 0.0) + duration
    return {phase: {who: _shares(zones) for who, zones in sorted(people.items())}
            for phase, people in sorted(seconds.items())}


def _shares(zones: Mapping[str, float]) -> dict[str, float]:
    total = sum(zones.values())
    shares = {name: round(zones.get(name, 0.0) / total, 4) if total else 0.0
              for name, _ in ZONES}
    return {**shares, "seconds": round(total, 3)}


# ------------------------------------------------------------------------------------ profile
def build_profile(*, shape: TreeShape, records: Iterable[TickRecord], phases: str | None,
                  bookings: Sequence[Booking] = (), proximity: Sequence[Proximity] = (),
                  checkpoints: Sequence[CheckpointMark] = (),
                  people: Sequence[PeopleSample] = (), end_s: float | None = None,
                  tree_file: str | None = None,
                  counts: Mapping[str, Sequence[int]] | None = None) -> dict[str, Any]:
    """The profile of one run (``profile.json``'s content; see the module docstring).

    ``counts``: the log's counts line (None: not in the log); ``people``: where everyone was,
    for the points' situations (:mod:`bt_servicesim.records.situations`)."""
    counter = NodeCounter(shape=shape, phases=phases)
    last_tick, last_time = 0, 0.0
    for record in records:
        counter.add(record)
        last_tick, last_time = record.tick, record.sim_time_s
    end = max(last_time, end_s or 0.0)
    counter.finish(end_s=end, end_tick=last_tick)
    if counts is not None:
        _use_counts(counter.figures, counts)
    phase_points: dict[str, dict[str, float]] = {}
    tip_points: dict[str, float] = {}
    total: dict[str, float] = {}
    booked = increments(bookings)
    for segment, change in spread(booked, counter.segments):
        phase = segment.phase if segment is not None else NO_PHASE
        _add(phase_points.setdefault(phase, {}), change)
        _add(total, change)
        if segment is not None and segment.tip in counter.figures:
            tip_points[segment.tip] = tip_points.get(segment.tip, 0.0) + sum(change.values())
    _points_up_the_tree(shape, counter.figures, tip_points)
    phase_time: dict[str, float] = {}
    for segment in counter.segments:
        phase_time[segment.phase] = phase_time.get(segment.phase, 0.0) + (
            segment.end_s - segment.start_s)
    phase_checkpoints: dict[str, list[dict[str, Any]]] = {}
    for mark in checkpoints:
        phase_checkpoints.setdefault(counter.phase_at(mark.sim_time_s - CHECKPOINT_LAG_S),
                                     []).append(
            {"name": mark.name, "sim_time_s": round(mark.sim_time_s, 3),
             "duration_s": round(mark.duration_s, 3)})
    phase_names = [phase for phase in _in_order([segment.phase for segment in counter.segments]
                                                + list(phase_points)) if phase != NO_PHASE]
    own_node = phase_nodes(shape, phases)
    last = counter.last_failure
    node_phase = phase_map(shape, phases)
    fired = _fired(shape, counter.figures)
    return {
        "version": PROFILE_VERSION,
        "tree_file": tree_file,
        "phases_composite": phases,
        "sim_time_s": round(end, 3),
        "ticks": last_tick,
        "penalties": {"by_cause": _rounded(total), "by_role": _rounded(by_role(total)),
                      "outside_phases": _rounded(by_role(phase_points.get(NO_PHASE, {}))),
                      "by_situation": situation_points(people, booked)},
        "phases": [{
            "phase": phase,
            "sim_time_s": round(phase_time.get(phase, 0.0), 3),
            "checkpoints": phase_checkpoints.get(phase, []),
            **_phase_outcome(counter.figures.get(own_node.get(phase, "")),
                             counter.phase_failures.get(phase)),
            "points": round(sum(phase_points.get(phase, {}).values()), 3),
            "penalties_by_role": _rounded(by_role(phase_points.get(phase, {}))),
            "penalties_by_cause": _rounded(phase_points.get(phase, {})),
        } for phase in phase_names],
        "proxemics": proxemics(proximity, end_s=end, phase_at=counter.phase_at),
        "last_failure": None if last is None else {
            "tick": last[0], "sim_time_s": round(last[1], 3), "node": last[2],
            "phase": node_phase.get(last[2], NO_PHASE), "reason": last[3]},
        "nodes": {key: {"label": node.label, "kind": node.kind, "type": node.type,
                        "phase": node_phase.get(key, NO_PHASE),
                        **counter.figures[key].to_json(),
                        **({"fired": fired[key]} if key in fired else {})}
                  for key, node in zip(shape.keys, shape.nodes, strict=True)},
        "timeline": timeline(counter.segments, booked),
    }


def timeline(segments: Sequence[Segment], booked: Sequence[tuple[float, float, Mapping[
        str, float]]]) -> dict[str, list[list[Any]]]:
    """The profile's ``timeline`` (see the module docstring)."""
    return {
        "segments": [[round(segment.start_s, 3), round(segment.end_s, 3), segment.tip,
                      segment.phase] for segment in segments],
        "bookings": [[round(end, 3), cause, round(points, 3)] for _, end, change in booked
                     for cause, points in sorted(by_role(change).items())],
    }


def _fired(shape: TreeShape, figures: Mapping[str, NodeFigures]) -> dict[str, int]:
    """How often each Retry and RecoveryNode fired (see the module docstring)."""
    children: dict[int, list[int]] = {}
    for index, node in enumerate(shape.nodes):
        if node.parent is not None:
            children.setdefault(node.parent, []).append(index)
    fired = {}
    for index, node in enumerate(shape.nodes):
        below = [figures[shape.nodes[child].key] for child in children.get(index, [])]
        if node.type == "RecoveryNode" and len(below) >= 2:
            fired[node.key] = below[1].starts
        elif node.type == "Retry" and below:
            fired[node.key] = max(0, below[0].failure - figures[node.key].failure)
    return fired


def _use_counts(figures: Mapping[str, NodeFigures],
                counts: Mapping[str, Sequence[int]]) -> None:
    """Replace the counts the changes showed with those the tree counted as it ticked."""
    for key, node in figures.items():
        node.ticks, node.starts, node.success, node.failure = counts.get(key, (0, 0, 0, 0))


def _phase_outcome(figures: NodeFigures | None, last_inside: int | None) -> dict[str, Any]:
    """Whether the phase's own node succeeded, its attempts, and the tick its last attempt
    failed (else, for a phase cut short, that of the last telling failure inside it)."""
    if figures is None:
        return {"succeeded": None, "attempts": 0, "last_failure_tick": last_inside}
    return {"succeeded": figures.success > 0, "attempts": figures.starts,
            "last_failure_tick": figures.last_failure_tick or last_inside}


def _points_up_the_tree(shape: TreeShape, figures: dict[str, NodeFigures],
                        tip_points: Mapping[str, float]) -> None:
    keys = shape.keys
    for key, points in tip_points.items():
        figures[key].points_tip += points
    for index in reversed(range(len(shape.nodes))):  # children before their parents
        node = figures[keys[index]]
        node.points_under += node.points_tip
        parent = shape.nodes[index].parent
        if parent is not None:
            figures[keys[parent]].points_under += node.points_under


def _in_order(names: Iterable[str]) -> list[str]:
    seen: dict[str, None] = {}
    for name in names:
        seen.setdefault(name, None)
    return list(seen)


def add_bounds(profile: dict[str, Any], legs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The profile with each phase's share of the task's kinematic bound and its time over it.

    ``legs``: the bound's legs (``servicesim_sim.task_bound``: checkpoint, bound_s). A phase's
    bound is that of the checkpoints it booked; its time over the bound is its sim time over
    that (None when it booked no checkpoint with a bound)."""
    bound_of = {str(leg["checkpoint"]): float(leg["bound_s"]) for leg in legs}
    total = sum(bound_of.values())
    for phase in profile["phases"]:
        bound = sum(bound_of.get(mark["name"], 0.0) for mark in phase["checkpoints"])
        phase["bound_s"] = round(bound, 3) if phase["checkpoints"] else None
        phase["bound_share"] = round(bound / total, 4) if total and phase["checkpoints"] else None
        phase["time_over_bound"] = (round(phase["sim_time_s"] / bound, 3)
                                    if bound > 0 else None)
    profile["bound_s"] = round(total, 3)
    return profile


def penalties_explained(profile: Mapping[str, Any] | None) -> dict[str, Any]:
    """What ``report.json`` says of the points' causes, from the run's profile: the points by
    penalty and what it was near (``penalties_by_cause``: ``approximation/walker``...) and by
    phase (``penalties_by_phase``: phase -> the same); both None without a profile."""
    if profile is None:
        return {"penalties_by_cause": None, "penalties_by_phase": None}
    return {"penalties_by_cause": dict(profile["penalties"]["by_role"]),
            "penalties_by_phase": {phase["phase"]: dict(phase["penalties_by_role"])
                                   for phase in profile["phases"]}}

