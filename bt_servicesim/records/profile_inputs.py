"""What a profile is built from, read back from a run's ``run.mcap``.

Records, never inputs to the mission. From the recording, in the order the messages arrived:

* :data:`PENALTY_CAUSES_TOPIC` (``std_msgs/String``, JSON ``{"sim_time_s": T, "sums": {CAUSE:
  POINTS}}``): the simulator's running sums of points by cause, booked where it computes the
  depths (:mod:`bt_servicesim.records.profile` says what a cause key is). A backend without it
  (Gazebo's ServiceSim, an older recording) leaves the referee's own totals
  (``/servicesim/referee``: approximation and contact), booked as ``unattributed``;
* the referee's state: when each checkpoint was booked, and its time;
* the people's ground truth (``/servicesim/actors``, with roles) and the robot's
  (``/servicesim/ground_truth/odom``): the distance to the guest and to the nearest other
  person, at every people message.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.records import Message
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message
from servicesim_competition.msg import RefereeState
from std_msgs.msg import String

from bt_servicesim.records.mcap import GROUND_TRUTH_TOPIC, PENALTY_CAUSES_TOPIC
from bt_servicesim.records.profile import Booking, CheckpointMark, Proximity
from bt_servicesim.records.recording import recorded_people
from bt_servicesim.records.situations import PeopleSample
from bt_servicesim.ros.planar_cdr import odometry_pose

DEFAULT_PHASES = "Mission"
"""The phases' composite of a log that does not name it (the shipped tree's,
:data:`bt_servicesim.tree.loading.DEFAULT_PHASES`)."""

REFEREE_TOPIC, ACTORS_TOPIC = "/servicesim/referee", "/servicesim/actors"


@dataclass
class ProfileInputs:
    """The samples a profile needs, in time order."""

    bookings: list[Booking] = field(default_factory=list)
    referee_bookings: list[Booking] = field(default_factory=list)
    proximity: list[Proximity] = field(default_factory=list)
    checkpoints: list[CheckpointMark] = field(default_factory=list)
    people: list[PeopleSample] = field(default_factory=list)
    end_s: float = 0.0
    robot: tuple[float, float] | None = None
    _done: tuple[bool, ...] = ()

    @property
    def attributed(self) -> list[Booking]:
        """The simulator's attributed sums, else the referee's totals."""
        return self.bookings or self.referee_bookings


def read_profile_inputs(mcap_path: Path) -> ProfileInputs:
    """Every sample from the recording (see the module docstring)."""
    with mcap_path.open("rb") as stream:
        return profile_inputs_of(
            (channel.topic, message) for _schema, channel, message in make_reader(
                stream).iter_messages(topics=list(PROFILE_TOPICS), log_time_order=False))


def profile_inputs_of(messages: Iterable[tuple[str, Message]]) -> ProfileInputs:
    """Every sample from recorded ``messages`` (topic, message) in the order written; topics
    other than :data:`PROFILE_TOPICS` are passed over."""
    inputs = ProfileInputs()
    for topic, message in messages:
        handler = _HANDLERS.get(topic)
        if handler is not None:
            now = message.log_time / 1e9
            inputs.end_s = max(inputs.end_s, now)
            handler(inputs, now, message.data)
    return inputs


def _on_causes(inputs: ProfileInputs, now: float, data: bytes) -> None:
    content: dict[str, Any] = json.loads(deserialize_message(data, String).data)
    sums = {str(cause): float(value) for cause, value in content.get("sums", {}).items()}
    inputs.bookings.append(Booking(sim_time_s=float(content.get("sim_time_s", now)), sums=sums))


def _on_referee(inputs: ProfileInputs, now: float, data: bytes) -> None:
    state = deserialize_message(data, RefereeState)
    inputs.referee_bookings.append(Booking(sim_time_s=now, sums={
        "approximation/unattributed": float(state.approximation),
        "contact/unattributed": float(state.contact)}))
    done = tuple(bool(value) for value in state.checkpoint_done)
    for index, (name, now_done) in enumerate(zip(state.checkpoint_names, done, strict=True)):
        was_done = index < len(inputs._done) and inputs._done[index]
        if now_done and not was_done:
            inputs.checkpoints.append(CheckpointMark(
                name=str(name), sim_time_s=now,
                duration_s=float(state.checkpoint_sim_time[index])))
    inputs._done = done


def _on_robot(inputs: ProfileInputs, now: float, data: bytes) -> None:
    read = odometry_pose(data)
    if read is None:  # not little-endian plain CDR
        position = deserialize_message(data, Odometry).pose.pose.position
        inputs.robot = (float(position.x), float(position.y))
    else:
        inputs.robot = (read[1].x, read[1].y)


def _on_actors(inputs: ProfileInputs, now: float, data: bytes) -> None:
    if inputs.robot is None:
        return
    message = recorded_people(data)
    x, y = inputs.robot
    guest: float | None = None
    others: float | None = None
    inputs.people.append(PeopleSample(sim_time_s=now, robot=(x, y), people={
        name: (role, px, py)
        for name, role, (px, py) in zip(message.names, message.roles, message.positions,
                                        strict=True)}))
    for role, (px, py) in zip(message.roles, message.positions, strict=True):
        distance = math.hypot(px - x, py - y)
        if role == "guest":
            guest = distance if guest is None else min(guest, distance)
        else:
            others = distance if others is None else min(others, distance)
    inputs.proximity.append(Proximity(sim_time_s=now, guest_m=guest, others_m=others))


_HANDLERS: dict[str, Callable[[ProfileInputs, float, bytes], None]] = {
    PENALTY_CAUSES_TOPIC: _on_causes, REFEREE_TOPIC: _on_referee,
    ACTORS_TOPIC: _on_actors, GROUND_TRUTH_TOPIC: _on_robot,
}
PROFILE_TOPICS = tuple(_HANDLERS)
"""The recorded topics a profile is built from."""


def profile_of_run(run: Path, inputs: ProfileInputs | None = None) -> dict[str, Any]:
    """The profile of the run recorded in directory ``run`` (its tree log and run.mcap);
    ``inputs``: the recording's samples when already read (:func:`profile_inputs_of`)."""
    from bt_servicesim.records.mcap import MCAP_NAME
    from bt_servicesim.records.profile import build_profile
    from bt_servicesim.records.tree_log import LOG_NAME, read_records

    header, records = read_records(run / LOG_NAME)
    if inputs is None:
        inputs = read_profile_inputs(run / MCAP_NAME)
    return build_profile(shape=header.shape, records=records,
                         phases=header.phases or DEFAULT_PHASES,
                         bookings=inputs.attributed, proximity=inputs.proximity,
                         checkpoints=inputs.checkpoints, people=inputs.people,
                         end_s=inputs.end_s,
                         tree_file=header.tree_file, counts=header.counts)


def write_profile(run: Path, profile: dict[str, Any]) -> Path:
    """Write ``profile.json`` in ``run``, whole or not at all; its path."""
    from bt_servicesim.records.profile import PROFILE_NAME

    path = run / PROFILE_NAME
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(profile, indent=1, sort_keys=False) + "\n", encoding="utf-8")
    partial.replace(path)
    return path
