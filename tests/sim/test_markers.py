"""The simulator's markers: stable ids, distinct guest, the plan sent when it changes, nothing
left behind, and messages a viewer reads as the shapes described."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker

from servicesim_sim.model.markers import (
    AREA_NAMES_NS,
    AREAS_NS,
    GUEST_COLOUR,
    GUEST_NAME_NS,
    GUEST_NS,
    PEOPLE_NS,
    PLAN_NS,
    TASK_AREA_COLOURS,
    Kind,
    SceneTracker,
    Shape,
    Update,
    areas_update,
)
from servicesim_sim.world.files import AreaBox
from tests.sim.marker_reference import marker_array

AREAS = {"Cafe": AreaBox(0.0, 0.0, 4.0, 2.0), "Lobby": AreaBox(5.0, 1.0, 6.0, 3.0),
         "Kitchen": AreaBox(-3.0, -3.0, -1.0, -1.0)}
CROWD = [("human_1", "walker", 1.0, 2.0), ("human_2", "idler", -1.0, 0.5),
         ("human_9", "guest", 3.0, 3.0)]


def test_every_area_is_a_flat_box_with_its_name_and_the_tasks_areas_say_their_role() -> None:
    update = areas_update(AREAS, roles={"Lobby": "pick-up", "Kitchen": "start"})
    assert update.clear == [AREAS_NS, AREA_NAMES_NS]
    boxes = [shape for shape in update.add if shape.namespace == AREAS_NS]
    names = [shape for shape in update.add if shape.namespace == AREA_NAMES_NS]
    assert [box.id for box in boxes] == [name.id for name in names] == [0, 1, 2]
    assert [name.text for name in names] == ["Cafe", "Lobby (pick-up)", "Kitchen (start)"]
    cafe = boxes[0]
    assert cafe.kind == Kind.CUBE and cafe.position[:2] == (2.0, 1.0)
    assert cafe.scale[:2] == (4.0, 2.0) and cafe.scale[2] < 0.05
    assert boxes[1].colour == TASK_AREA_COLOURS["pick-up"]
    assert boxes[2].colour == TASK_AREA_COLOURS["start"] != boxes[1].colour != cafe.colour
    assert all(name.kind == Kind.TEXT_VIEW_FACING for name in names)


def test_people_keep_their_ids_and_the_guest_is_drawn_apart_in_its_own_colour() -> None:
    tracker = SceneTracker()
    first = tracker.update(CROWD, plan=[])
    assert first.clear == [PEOPLE_NS, GUEST_NS, GUEST_NAME_NS, PLAN_NS]
    people = {shape.id: shape for shape in first.add if shape.namespace == PEOPLE_NS}
    assert sorted(people) == [0, 1] and people[0].position[:2] == (1.0, 2.0)
    assert all(shape.kind == Kind.CYLINDER and shape.colour != GUEST_COLOUR
               for shape in people.values())
    guest = [shape for shape in first.add if shape.namespace == GUEST_NS]
    assert len(guest) == 1 and guest[0].colour == GUEST_COLOUR
    assert guest[0].position[:2] == (3.0, 3.0) and guest[0].kind == Kind.CYLINDER
    label = [shape for shape in first.add if shape.namespace == GUEST_NAME_NS]
    assert [shape.text for shape in label] == ["guest human_9"]
    again = tracker.update(CROWD, plan=[])
    assert again == Update(), "nobody moved: nothing to send"
    moved = tracker.update([CROWD[1], ("human_1", "walker", 1.5, 2.0), CROWD[2]], plan=[])
    assert not moved.clear and not moved.delete
    assert [(shape.namespace, shape.id, shape.position[:2]) for shape in moved.add] == [
        (PEOPLE_NS, 0, (1.5, 2.0))]


def test_every_tenth_update_sends_everyone_for_viewers_that_joined_late() -> None:
    tracker = SceneTracker(full_every=3)
    path = [(0.0, 0.0), (1.0, 0.0)]
    sent = [tracker.update(CROWD, plan=path) for _ in range(7)]
    assert [len(update.add) for update in sent] == [5, 0, 0, 5, 0, 0, 5]
    assert all(update.add[-1].namespace == PLAN_NS for update in sent[::3])
    assert SceneTracker().full_every == 10


def test_a_person_who_is_gone_is_deleted_and_a_newcomer_gets_a_new_id() -> None:
    tracker = SceneTracker()
    tracker.update(CROWD, plan=[])
    update = tracker.update([CROWD[1], ("human_7", "walker", 0.0, 0.0)], plan=[])
    assert update.delete == [(PEOPLE_NS, 0)]
    assert [shape.id for shape in update.add if shape.namespace == PEOPLE_NS] == [2]


def test_the_plan_is_sent_when_it_changes_and_deleted_when_no_goal_runs() -> None:
    tracker = SceneTracker()
    path = [(0.0, 0.0), (1.0, 0.0), (1.0, 2.0)]

    def plans(update: Update) -> list[Shape]:
        return [shape for shape in update.add if shape.namespace == PLAN_NS]

    first = tracker.update(CROWD, plan=path)
    assert [shape.points for shape in plans(first)] == [tuple(path)]
    assert plans(first)[0].kind == Kind.LINE_STRIP
    assert plans(tracker.update(CROWD, plan=list(path))) == []
    assert [shape.points for shape in plans(tracker.update(CROWD, plan=path[1:]))] == [
        tuple(path[1:])]
    ended = tracker.update(CROWD, plan=[])
    assert ended.delete == [(PLAN_NS, 0)] and plans(ended) == []
    assert tracker.update(CROWD, plan=[]).delete == []


def test_messages_clear_first_then_delete_then_add_in_the_map_frame() -> None:
    tracker = SceneTracker(full_every=1)
    tracker.update(CROWD, plan=[(0.0, 0.0), (2.0, 0.0)])
    update = tracker.update(CROWD[1:], plan=[])
    update.clear = [PEOPLE_NS]
    message = marker_array(update, now=Time(sec=7))
    actions = [marker.action for marker in message.markers]
    assert actions == [Marker.DELETEALL, Marker.DELETE, Marker.DELETE] + [Marker.ADD] * 3
    assert [(marker.ns, marker.id) for marker in message.markers[1:3]] == [
        (PEOPLE_NS, 0), (PLAN_NS, 0)]
    assert {marker.header.frame_id for marker in message.markers} == {"map"}
    assert {marker.header.stamp.sec for marker in message.markers} == {7}
    guest = next(marker for marker in message.markers if marker.ns == GUEST_NS)
    assert guest.type == Marker.CYLINDER and guest.pose.orientation.w == 1.0
    assert (guest.color.r, guest.color.g, guest.color.b, guest.color.a) == GUEST_COLOUR


def test_shape_kinds_are_numbered_as_markers_types() -> None:
    assert (Kind.CUBE, Kind.CYLINDER, Kind.LINE_STRIP, Kind.TEXT_VIEW_FACING) == (
        Marker.CUBE, Marker.CYLINDER, Marker.LINE_STRIP, Marker.TEXT_VIEW_FACING)


def test_a_plan_line_carries_its_points_and_width() -> None:
    tracker = SceneTracker()
    update = tracker.update([], plan=[(0.0, 0.0), (1.0, 1.0)])
    message = marker_array(update, now=Time())
    line = next(marker for marker in message.markers if marker.ns == PLAN_NS
                and marker.action == Marker.ADD)
    assert [(point.x, point.y) for point in line.points] == [(0.0, 0.0), (1.0, 1.0)]
    assert line.scale.x > 0.0
