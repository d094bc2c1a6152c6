"""The records a run keeps in its directory, made on the executive's node.

The tree's snapshot log (``tree_log.jsonl``), its final tick (``final_tree.txt``) and the
mission profile built from the records (``profile.json``, :mod:`bt_servicesim.records.profile`)
when the executive is a behaviour tree, the trajectory picture (``trajectory.png``) and the ROS
traffic (``run.mcap``). They are written on every way out, a signal included; a record that
cannot be written costs a warning line, never the report. The picture and the profile are both
built from the recording, read back once for the two: parsing an MCAP file is most of what
either costs.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import py_trees
from mcap.records import Message
from rclpy.node import Node

from bt_servicesim.monitor.live_server import LiveServer
from bt_servicesim.records.mcap import (
    MCAP_NAME,
    TASK_TOPIC,
    TREE_TOPIC,
    McapRecorder,
    TaskTopic,
    TreeTopic,
)
from bt_servicesim.records.profile import PROFILE_NAME
from bt_servicesim.records.profile_inputs import (
    PROFILE_TOPICS,
    profile_inputs_of,
    profile_of_run,
    write_profile,
)
from bt_servicesim.records.recording import RecordingError, recorded_messages
from bt_servicesim.records.trajectory import (
    TRACE_TOPICS,
    TRAJECTORY_NAME,
    boxes_from_blackboard,
    render_trajectory,
    trace_from_recording,
    trace_of,
)
from bt_servicesim.records.tree_log import LOG_NAME, TreeLog, behaviour_tree_of
from bt_servicesim.ros.lockstep import LockstepHost
from bt_servicesim.ros.sim_clock import sim_now_s
from bt_servicesim.tree.executive import Executive
from bt_servicesim.tree.shape import ShadowTree

if TYPE_CHECKING:
    from bt_servicesim.monitor.foxglove_bridge import FoxgloveBridge

FINAL_TREE_NAME = "final_tree.txt"


def _foxglove_bridge(node: Node, server: LiveServer) -> FoxgloveBridge:
    """The bridge to a Foxglove server, with the Foxglove SDK it loads: only a run that serves
    one (run --foxglove) needs them."""
    from bt_servicesim.monitor.foxglove_bridge import FoxgloveBridge

    return FoxgloveBridge(node=node, server=server)


class RunRecords:
    """The run's records in its directory (see the module docstring), made on ``node``."""

    def __init__(self, *, node: Node, executive: Executive, out: Path, tree_file: Path,
                 live_server: LiveServer | None = None, profile: bool = True) -> None:
        """``live_server``: also forward the recorded topics to this Foxglove server;
        ``profile``: count the nodes' ticks and write ``profile.json``."""
        self.out = out
        self.tree = behaviour_tree_of(executive)
        self.mcap = McapRecorder(node=node, path=out / MCAP_NAME,
                                 own_topics=(TASK_TOPIC, TREE_TOPIC))
        self.task = TaskTopic(node=node, recorder=self.mcap)
        self.live = None if live_server is None else _foxglove_bridge(node, live_server)
        # the picture is drawn from the recording after the run: decoding the people's
        # positions as they come would cost the executive a tenth of its time
        self.phases: list[tuple[float, str]] = []
        self._node = node
        self._host = node if isinstance(node, LockstepHost) else None
        """The node as lockstep's host, looked up once: a runtime protocol check costs tens of
        microseconds, too much for every tick."""
        self._profile = profile
        self.profile: dict[str, Any] | None = None
        """The run's profile once written (:meth:`finish`); None before, or without one."""
        self.tree_log: TreeLog | None = None
        self.tree_topic: TreeTopic | None = None
        if self.tree is not None:
            self.tree_log = TreeLog(tree=self.tree, path=out / LOG_NAME,
                                    sim_time_s=lambda: sim_now_s(node.get_clock()),
                                    tree_file=str(tree_file),
                                    phases=getattr(executive, "phases", None), count=profile)
            self.tree_topic = TreeTopic(node=node, recorder=self.mcap, phase=executive.phase)
            self.tree_log.listeners.append(self.tree_topic.publish)
            self.tree.add_post_tick_handler(self._log_tick)

    def _log_tick(self, tree: py_trees.trees.BehaviourTree) -> None:
        """Log the tick, after its lockstep done when there is one (free running: now)."""
        assert self.tree_log is not None
        log, tick = self.tree_log.log, tree.count + 1  # py_trees counts after the handlers
        client = None if self._host is None else self._host.lockstep
        if client is None:
            log(tick=tick)
        else:
            client.after_done(lambda: log(tick=tick))

    def note_phase(self, phase: str) -> None:
        """The mission's phase now (the executive's ``phase()``), kept for the picture."""
        if not self.phases or self.phases[-1][1] != phase:
            self.phases.append((sim_now_s(self._node.get_clock()), phase))

    def finish(self, *, title: str, trajectory: bool = True) -> None:
        """Write what is written at the end and close the rest; a failure is a warning.

        ``trajectory``: draw the trajectory picture (else it can be drawn later from the
        recording, ``python -m bt_servicesim.trajectory DIR``)."""
        steps: list[tuple[str, Callable[[], None]]] = [
            (MCAP_NAME, self._close_recording),  # the picture is drawn from the finished recording
        ]
        if trajectory:
            steps.append((TRAJECTORY_NAME, lambda: self._render_trajectory(title)))
        if self.tree_log is not None:
            steps += [(LOG_NAME, self.tree_log.close), (FINAL_TREE_NAME, self._write_final_tree)]
            if self._profile:
                steps.append((PROFILE_NAME, self._write_profile))
        for name, step in steps:
            try:
                step()
            except Exception as error:  # a record is not worth losing the report for
                print(f"warning: could not write {self.out / name}: {error}", file=sys.stderr)

    @cached_property
    def _recorded(self) -> list[tuple[str, Message]] | None:
        """The recorded messages the picture and the profile are built from, read once for
        both; None when the recording cannot be read whole: each then reads it as it does
        alone (a picture of what was read before a cut, or a warning)."""
        try:
            return [(channel.topic, message) for channel, message in recorded_messages(
                self.out / MCAP_NAME, topics=sorted({*TRACE_TOPICS, *PROFILE_TOPICS}))]
        except RecordingError:
            return None

    def _write_profile(self) -> None:
        recorded = self._recorded
        self.profile = profile_of_run(
            self.out, None if recorded is None else profile_inputs_of(recorded))
        write_profile(self.out, self.profile)

    def _close_recording(self) -> None:
        if self.live is not None:
            self.live.close()
        if self.tree_topic is not None:
            self.tree_topic.flush()  # the last state, if the period held it back
        self.mcap.close()

    def _render_trajectory(self, title: str) -> None:
        boxes = boxes_from_blackboard(py_trees.blackboard.Blackboard.storage)
        recorded = self._recorded
        trace = (trace_from_recording(self.out / MCAP_NAME, phases=self.phases)
                 if recorded is None else trace_of(recorded, phases=self.phases))
        render_trajectory(trace, path=self.out / TRAJECTORY_NAME, boxes=boxes,
                          title=title)

    def _write_final_tree(self) -> None:
        """The last *ticked* state: after Ctrl-C the live tree has been stopped (all INVALID)."""
        assert self.tree_log is not None
        shadow = ShadowTree(self.tree_log.shape)
        nodes, tip = self.tree_log.latest
        shadow.show(nodes, tip=tip)
        (self.out / FINAL_TREE_NAME).write_text(shadow.text(), encoding="utf-8")
