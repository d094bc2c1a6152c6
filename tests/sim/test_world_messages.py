"""The world's state messages, serialised by hand: what rclpy would send, field for field and
in length (as tests/sim/test_pose_messages.py checks the pose messages), for names, roles and
states of varied lengths (which move the alignment of what follows) and a real engine's
people and referee."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from rclpy.serialization import deserialize_message, serialize_message
from servicesim_competition.msg import ActorStates, RefereeState

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.wire.world_messages import ActorStatesBytes, RefereeStateBytes
from servicesim_sim.world.files import DEFAULT_WORLD, load_world

STAMPS = [(0, 0), (1, 999_999_999), (233, 960_000_000), (2**31 - 1, 5)]
GUEST_STATES = ["waiting", "following", "lost", "drifted", ""]


def same(ours: bytes, theirs: bytes, kind: type) -> Any:
    """Both decode to equal messages of the same length; ours decoded."""
    assert len(ours) == len(theirs)
    read = deserialize_message(ours, kind)
    assert read == deserialize_message(theirs, kind)
    return read


def rclpy_actor_states(stamp: tuple[int, int], people: list[tuple[str, str, float, float]],
                       guest_state: str) -> ActorStates:
    """As the node built it with rclpy."""
    message = ActorStates(guest_state=guest_state)
    message.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    for name, role, x, y in people:
        message.names.append(name)
        message.roles.append(role)
        message.positions.append(Point(x=float(x), y=float(y)))
    return message


@pytest.mark.parametrize("stamp", STAMPS)
def test_actor_states_of_people_with_names_and_roles_of_every_length(
        stamp: tuple[int, int]) -> None:
    rng = np.random.default_rng(stamp[0])
    for count in (0, 1, 2, 3, 7, 41):
        people = [("h" * int(rng.integers(0, 13)), "r" * int(rng.integers(0, 9)),
                   float(rng.normal(0, 20)), float(rng.normal(0, 20))) for _ in range(count)]
        encoder = ActorStatesBytes(names=[p[0] for p in people], roles=[p[1] for p in people])
        for guest_state in GUEST_STATES:
            ours = encoder.encode(stamp=stamp, positions=[(x, y) for _, _, x, y in people],
                                  guest_state=guest_state)
            read = same(ours, serialize_message(rclpy_actor_states(stamp, people, guest_state)),
                        ActorStates)
            assert [(p.x, p.y, p.z) for p in read.positions] == [
                (x, y, 0.0) for _, _, x, y in people]


def test_actor_states_refuse_names_and_roles_that_do_not_pair() -> None:
    with pytest.raises(ValueError, match="2 names but 1 roles"):
        ActorStatesBytes(names=["a", "b"], roles=["walker"])


def rclpy_referee_state(stamp: tuple[int, int], values: dict[str, Any]) -> RefereeState:
    state = RefereeState()
    state.stamp = Time(sec=stamp[0], nanosec=stamp[1])
    for key, value in values.items():
        setattr(state, key, value)
    return state


@pytest.mark.parametrize("stamp", STAMPS)
def test_referee_states_of_every_shape(stamp: tuple[int, int]) -> None:
    rng = np.random.default_rng(stamp[1])
    for count in (0, 1, 3, 4, 5):
        names = ["c" * int(rng.integers(0, 14)) for _ in range(count)]
        encoder = RefereeStateBytes(names=names)
        for _ in range(20):
            values = {"task_running": bool(rng.integers(2)),
                      "completed": bool(rng.integers(2)), "score": float(rng.normal(0, 1e4)),
                      "task_sim_time": float(rng.uniform(0, 900)),
                      "checkpoint_names": names,
                      "checkpoint_done": [bool(rng.integers(2)) for _ in names],
                      "checkpoint_sim_time": [float(rng.uniform(0, 500)) for _ in names],
                      "failed_pickups": int(rng.integers(0, 2**32)),
                      "failed_dropoffs": int(rng.integers(0, 9)),
                      "too_fast": int(rng.integers(0, 9)), "drifts": int(rng.integers(0, 30)),
                      "contact": float(rng.uniform(0, 1e6)), "approximation": math.pi}
            ours = encoder.encode(
                stamp=stamp, running=values["task_running"], completed=values["completed"],
                score=values["score"], task_sim_time=values["task_sim_time"],
                done=values["checkpoint_done"], times=values["checkpoint_sim_time"],
                counts=(values["failed_pickups"], values["failed_dropoffs"],
                        values["too_fast"], values["drifts"]),
                contact=values["contact"], approximation=values["approximation"])
            same(ours, serialize_message(rclpy_referee_state(stamp, values)), RefereeState)


def test_a_real_engines_people_and_books_as_the_topics_send_them() -> None:
    from servicesim_sim.ros.world_topics import WorldTopics

    office = load_world(DEFAULT_WORLD)
    engine = SimEngine(world=office, scenario=make_scenario(office, seed=5))
    engine.new_task()
    topics = WorldTopics.__new__(WorldTopics)  # its messages alone, without a node
    topics.engine = engine
    topics._actors_bytes = topics._referee_bytes = None
    engine.command_velocity(0.5, 0.2)
    for step in range(1, 600):
        engine.step()
        if step % 25:
            continue
        sec, nanosec = divmod(round(engine.sim_time * 1e9), 1_000_000_000)
        states = engine.people_states()
        same(topics._actor_states(), serialize_message(rclpy_actor_states(
            (sec, nanosec), states, engine.guest_state())), ActorStates)
        report = engine.referee_report()
        penalties = report["penalties"]
        same(topics._referee_state(), serialize_message(rclpy_referee_state((sec, nanosec), {
            "task_running": report["running"], "completed": report["completed"],
            "score": report["score"], "task_sim_time": report["task_sim_time"],
            "checkpoint_names": [c["name"] for c in report["checkpoints"]],
            "checkpoint_done": [c["done"] for c in report["checkpoints"]],
            "checkpoint_sim_time": [c["sim_time_s"] for c in report["checkpoints"]],
            "failed_pickups": penalties["failed_pickup"],
            "failed_dropoffs": penalties["failed_dropoff"],
            "too_fast": penalties["too_fast"], "drifts": penalties["drifts"],
            "contact": penalties["contact"], "approximation": penalties["approximation"]})),
            RefereeState)
