"""The people's messages, serialised by hand: what rclpy would send, field for field and in
length, for varied people (names of lengths that move the alignment, nobody at all), guest
states and stamps, and as the people change from one message to the next."""

from __future__ import annotations

import pytest
from geometry_msgs.msg import Point
from rclpy.serialization import deserialize_message, serialize_message
from servicesim_competition.msg import ActorNames, ActorStates

from servicesim_sim.wire.actor_messages import NAMES_KEPT, ActorNamesBytes, ActorStatesBytes

PEOPLE = [("human_55686", "guest", -16.5, 10.025), ("human_00001", "walker", 1e-9, -3.0),
          ("a", "idler", 7.25, 2.0), ("abcd", "walker", -0.0, 1e6), ("", "idler", 3.0, 4.0)]


def by_rclpy(stamp: tuple[int, int], people: list[tuple[str, str, float, float]],
             guest_state: str) -> bytes:
    message = ActorStates()
    message.stamp.sec, message.stamp.nanosec = stamp
    for name, role, x, y in people:
        message.names.append(name)
        message.roles.append(role)
        message.positions.append(Point(x=float(x), y=float(y)))
    message.guest_state = guest_state
    return serialize_message(message)


def same(ours: bytes, theirs: bytes, kind: type) -> object:
    assert len(ours) == len(theirs)
    read = deserialize_message(ours, kind)
    assert read == deserialize_message(theirs, kind)
    return read


@pytest.mark.parametrize("count", range(len(PEOPLE) + 1))
@pytest.mark.parametrize("guest_state", ["waiting", "following", "lost", "drifted", ""])
@pytest.mark.parametrize("stamp", [(0, 0), (233, 960_000_000)])
def test_actor_states_are_rclpys_own(count: int, guest_state: str,
                                     stamp: tuple[int, int]) -> None:
    people = PEOPLE[:count]
    ours = ActorStatesBytes().encode(stamp=stamp, people=people, guest_state=guest_state)
    read = same(ours, by_rclpy(stamp, people, guest_state), ActorStates)
    assert [(p.x, p.y) for p in read.positions] == [(x, y) for _, _, x, y in people]


def test_actor_states_follow_the_people_as_they_change() -> None:
    encoder = ActorStatesBytes()
    for people in (PEOPLE, PEOPLE, PEOPLE[1:], PEOPLE[::-1], [], PEOPLE[:2],
                   [(n, r, x + 1.0, y) for n, r, x, y in PEOPLE[:2]]):
        ours = encoder.encode(stamp=(5, 6), people=people, guest_state="following")
        same(ours, by_rclpy((5, 6), people, "following"), ActorStates)


@pytest.mark.parametrize("names", [[], ["a"], ["ab", "abc"], ["abcd", "", "human_55686"]])
def test_actor_names_are_rclpys_own(names: list[str]) -> None:
    encoder = ActorNamesBytes()
    for _ in range(2):  # made, then kept
        read = same(encoder.encode(names), serialize_message(ActorNames(actor_names=names)),
                    ActorNames)
        assert read.actor_names == names


def test_actor_names_kept_are_bounded() -> None:
    encoder = ActorNamesBytes()
    for number in range(3 * NAMES_KEPT):
        names = [f"human_{number:05d}"]
        assert deserialize_message(encoder.encode(names), ActorNames).actor_names == names
    assert len(encoder._kept) == NAMES_KEPT
