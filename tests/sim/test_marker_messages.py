"""The scene's markers, serialised by hand: the bytes rclpy serialises of ``marker_array`` for
the same update (the reference the simulator published before), for made-up updates that move
the alignment and for a real engine's scenes, one after another.

rclpy's bytes (Fast CDR) leave the alignment padding unwritten: it holds whatever the buffer
held before, so it changes from call to call. The bytes are therefore compared three ways:
byte for byte with mcap_ros2's CDR writer (another implementation, which zeroes the padding)
fed the same rclpy message; in length with rclpy's, differing only where ours are zero; and as
rclpy reads them back."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from functools import cache

import pytest
from builtin_interfaces.msg import Time
from mcap_ros2._dynamic import serialize_dynamic
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from bt_servicesim.records.mcap import complete_definition
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.markers import (
    PEOPLE_NS,
    PLAN_NS,
    Kind,
    SceneTracker,
    Shape,
    Update,
    areas_update,
    guest_shapes,
    person_shape,
    plan_shape,
)
from servicesim_sim.model.scenario import make_scenario
from servicesim_sim.wire.marker_messages import MarkerArrayBytes
from servicesim_sim.world.files import DEFAULT_WORLD, AreaBox, World, load_world
from tests.sim.marker_reference import marker_array

STAMPS = [(0, 0), (7, 500_000_000), (233, 960_000_001)]
CROWD = [("human_1", "walker", 1.0, 2.0), ("human_2", "idler", -1.0, 0.5),
         ("human_33", "walker", -0.0, 1e6), ("human_9", "guest", 3.0, 3.0)]
PATH = [(0.0, 0.0), (1.0, 0.0), (1.0, 2.5), (-3.25, 2.5)]
STEPS_PER_UPDATE = 25  # 0.5 sim s of 50 Hz physics


MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"


@cache
def zero_padded_cdr() -> Callable[[MarkerArray], bytes]:
    """mcap_ros2's encoder of a ``MarkerArray``, from the installed ``.msg`` definitions."""
    return serialize_dynamic(MARKER_ARRAY, complete_definition(MARKER_ARRAY))[MARKER_ARRAY]


def rclpys(update: Update, stamp: tuple[int, int]) -> MarkerArray:
    return marker_array(update, now=Time(sec=stamp[0], nanosec=stamp[1]))


def same(ours: bytes, message: MarkerArray) -> MarkerArray:
    """``ours`` are ``message``'s bytes (module docstring); the message rclpy reads of them."""
    assert ours == zero_padded_cdr()(message)
    theirs = serialize_message(message)
    assert len(ours) == len(theirs)
    assert all(mine == 0 for mine, their in zip(ours, theirs, strict=True) if mine != their)
    read = deserialize_message(ours, MarkerArray)
    assert read == deserialize_message(theirs, MarkerArray)
    return read


def text(namespace: str, number: int, words: str) -> Shape:
    return Shape(namespace=namespace, id=number, kind=Kind.TEXT_VIEW_FACING,
                 position=(1.5, -2.0, 0.5), scale=(0.0, 0.0, 0.35), text=words)


# namespaces and texts of every length modulo 8 move the markers after them out of alignment
SHAPES = [
    person_shape(0, role="walker", x=1.0, y=2.0),
    person_shape(41, role="idler", x=-7.125, y=1e-9),
    *guest_shapes("human_20843", x=3.0, y=-4.5),
    plan_shape(PATH),
    plan_shape(PATH[:2]),
    *(text(f"n{'s' * length}", length, "t" * length) for length in range(9)),
    text("names", 3, "Café ☕ (pick-up)"),
]
UPDATES = {
    "empty": Update(),
    "one person": Update(add=SHAPES[:1]),
    "everything": Update(clear=["people", "guest", "a"], delete=[(PEOPLE_NS, 5), ("plan", 0)],
                         add=SHAPES),
    "deletes only": Update(delete=[(PEOPLE_NS, n) for n in range(5)] + [(PLAN_NS, 0)]),
    "clears only": Update(clear=["x", "people", "guest_name", "plan", ""]),
    "texts": Update(add=SHAPES[5:]),
    "areas": areas_update({"Cafe": AreaBox(0.0, 0.0, 4.0, 2.0),
                           "PrivateCubicle_32_1": AreaBox(5.0, 1.0, 6.0, 3.0),
                           "FrontElevator": AreaBox(-3.0, -3.0, -1.0, -1.0)},
                          roles={"FrontElevator": "pick-up", "Cafe": "start"}),
}


@pytest.mark.parametrize("stamp", STAMPS)
@pytest.mark.parametrize("name", sorted(UPDATES))
def test_an_update_is_rclpys_own_serialisation(name: str, stamp: tuple[int, int]) -> None:
    update = UPDATES[name]
    read = same(MarkerArrayBytes().encode(update, stamp=stamp), rclpys(update, stamp))
    assert len(read.markers) == len(update.clear) + len(update.delete) + len(update.add)
    assert all((marker.header.stamp.sec, marker.header.stamp.nanosec) == stamp
               for marker in read.markers)


@pytest.mark.parametrize("name", sorted(UPDATES))
def test_every_marker_reads_back_as_the_shape_it_draws(name: str) -> None:
    update = UPDATES[name]
    read = deserialize_message(MarkerArrayBytes().encode(update, stamp=(1, 2)), MarkerArray)
    added = read.markers[len(update.clear) + len(update.delete):]
    assert [marker.action for marker in read.markers] == (
        [Marker.DELETEALL] * len(update.clear) + [Marker.DELETE] * len(update.delete)
        + [Marker.ADD] * len(update.add))
    assert [(m.ns, m.id) for m in read.markers[len(update.clear):len(read.markers) - len(added)]
            ] == update.delete
    for marker, shape in zip(added, update.add, strict=True):
        assert (marker.ns, marker.id, marker.type, marker.text) == (
            shape.namespace, shape.id, int(shape.kind), shape.text)
        position = marker.pose.position
        assert (position.x, position.y, position.z) == shape.position
        assert marker.pose.orientation.w == 1.0 and marker.header.frame_id == "map"
        assert [(point.x, point.y, point.z) for point in marker.points] == [
            (x, y, shape.z) for x, y in shape.points]


def test_a_sequence_of_updates_is_rclpys_own_as_the_scene_changes() -> None:
    """People moving, leaving and coming; a plan appearing, changing and ending; the templates
    kept from one message serve the next, at whichever alignment a marker then falls."""
    tracker, encoder = SceneTracker(full_every=4), MarkerArrayBytes()
    crowd = list(CROWD)
    plans = [[], PATH, PATH, PATH[1:], PATH[1:], [], [], PATH[:2], [(0.5, 0.5)], PATH]
    for number, plan in enumerate(plans):
        crowd = [(name, role, x + 0.25 * (role == "walker"), y) for name, role, x, y in crowd]
        if number == 3:
            crowd = crowd[1:]
        if number == 6:
            crowd.insert(0, ("h", "walker", 2.0, 2.0))
        update = tracker.update(crowd, plan)
        stamp = (number, 500_000_000 * (number % 2))
        same(encoder.encode(update, stamp=stamp), rclpys(update, stamp))


@cache
def office() -> World:
    return load_world(DEFAULT_WORLD)


def engine_updates(seed: int, *, count: int) -> Iterator[Update]:
    """A real engine's scene every 0.5 sim s, the robot sent to the pick-up area."""
    engine = SimEngine(world=office(), scenario=make_scenario(office(), seed=seed))
    engine.navigate(*engine.world.areas[engine.scenario.task.pick_up].centre, 0.0)
    tracker = SceneTracker()
    for _ in range(count):
        for _ in range(STEPS_PER_UPDATE):
            engine.step()
        navigator = engine.navigator
        yield tracker.update(engine.people_states(),
                             navigator.path if navigator.status == "running" else [])


@pytest.mark.parametrize("seed", [1, 2])
def test_a_real_engines_scenes_are_rclpys_own(seed: int) -> None:
    encoder = MarkerArrayBytes()
    plans = 0
    for number, update in enumerate(engine_updates(seed, count=24)):
        stamp = (number // 2, 500_000_000 * (number % 2))
        read = same(encoder.encode(update, stamp=stamp), rclpys(update, stamp))
        plans += any(marker.ns == PLAN_NS for marker in read.markers)
    assert plans, "the robot's plan was drawn"


def test_the_templates_kept_are_bounded_by_the_markers_drawn() -> None:
    encoder = MarkerArrayBytes()
    for number in range(50):
        shapes = [person_shape(n, role="walker", x=number, y=n) for n in range(3)]
        encoder.encode(Update(delete=[(PEOPLE_NS, 9)] * (number % 2), add=shapes),
                       stamp=(number, 0))
    assert len(encoder._shapes) <= 3 * 2 and len(encoder._bare) <= 2
