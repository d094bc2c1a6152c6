"""The simulator's markers on ROS: ``visualization_msgs/MarkerArray`` in the ``map`` frame.

Two topics, so that a viewer that joins late, or a recording opened at any moment, still has
the building:

* ``/servicesim/markers/areas``: the target areas and their names, published once, latched
  (transient local), as a map is;
* ``/servicesim/markers``: the people, the guest and the robot's planned path, with the actors
  (every 0.5 sim s); only what :class:`~servicesim_sim.markers.SceneTracker` says changed is
  deleted, the people are sent every time (they move).

What is drawn and how is :mod:`servicesim_sim.markers`; this module only publishes the messages.
Both are sent as CDR bytes serialised by hand (:mod:`servicesim_sim.marker_messages`);
:func:`marker_array` builds the same message with rclpy, the reference those bytes are tested
against.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker, MarkerArray

from servicesim_sim.engine import SimEngine
from servicesim_sim.marker_messages import MAP_FRAME, MarkerArrayBytes
from servicesim_sim.markers import SceneTracker, Shape, Update, areas_update

MARKERS_TOPIC = "/servicesim/markers"
AREA_MARKERS_TOPIC = "/servicesim/markers/areas"


def marker_array(update: Update, *, now: Time, built: MarkerCache | None = None) -> MarkerArray:
    """The message for ``update``: a DELETEALL per cleared namespace, DELETEs, then ADDs;
    ``built`` keeps the markers made before, to refill rather than make again.

    The simulator sends :class:`~servicesim_sim.marker_messages.MarkerArrayBytes`' encoding
    instead; this is the rclpy message its bytes must equal once serialised."""
    cache = built if built is not None else MarkerCache()
    markers = [_bare(namespace, 0, Marker.DELETEALL, now) for namespace in update.clear]
    markers += [_bare(namespace, number, Marker.DELETE, now)
                for namespace, number in update.delete]
    markers += [cache.marker(shape, now) for shape in update.add]
    return MarkerArray(markers=markers)


def _bare(namespace: str, number: int, action: int, now: Time) -> Marker:
    marker = Marker(ns=namespace, id=number, action=action)
    marker.header.frame_id, marker.header.stamp = MAP_FRAME, now
    return marker


class MarkerCache:
    """The marker last made for each namespace and id, refilled when only its place changed.

    A person moves every update and looks the same: setting two numbers of the marker made
    before takes a fraction of making a ``Marker`` again (rclpy checks every field it is given).
    Publishing serialises at the call, so refilling a marker sent before changes nothing sent.
    """

    def __init__(self) -> None:
        self._made: dict[tuple[str, int], tuple[Shape, Marker]] = {}

    def marker(self, shape: Shape, now: Time) -> Marker:
        key = (shape.namespace, shape.id)
        made = self._made.get(key)
        if made is not None and _looks_alike(made[0], shape):
            marker = made[1]
            marker.header.stamp = now
            position = marker.pose.position
            position.x, position.y, position.z = shape.position
        else:
            marker = _marker(shape, now)
        self._made[key] = (shape, marker)
        return marker


def _looks_alike(old: Shape, new: Shape) -> bool:
    """Whether ``new`` is ``old`` moved: everything but the position alike."""
    return (old.kind == new.kind and old.scale == new.scale and old.colour == new.colour
            and old.text == new.text and old.points == new.points and old.z == new.z)


def _marker(shape: Shape, now: Time) -> Marker:
    marker = _bare(shape.namespace, shape.id, Marker.ADD, now)
    marker.type = int(shape.kind)
    position = marker.pose.position
    position.x, position.y, position.z = (float(value) for value in shape.position)
    marker.pose.orientation.w = 1.0
    marker.scale.x, marker.scale.y, marker.scale.z = (float(value) for value in shape.scale)
    colour = marker.color
    colour.r, colour.g, colour.b, colour.a = (float(value) for value in shape.colour)
    marker.text = shape.text
    marker.points = [Point(x=x, y=y, z=shape.z) for x, y in shape.points]
    return marker


class MarkerTopics:
    """Publishes the engine's scene: the areas at once, the rest on each :meth:`publish`.

    ``make_publisher(type, topic, qos)`` is the node's (the simulator's own wrapper);
    ``send(publisher, message)`` its guarded publish.
    """

    def __init__(self, *, engine: SimEngine, make_publisher: Callable[..., Any],
                 send: Callable[[Any, Any], None], latched: Any, now: Time) -> None:
        self.engine = engine
        self._send = send
        self._scene = make_publisher(MarkerArray, MARKERS_TOPIC, 10)
        self._areas = make_publisher(MarkerArray, AREA_MARKERS_TOPIC, latched)
        self._tracker = SceneTracker()
        self._encoder = MarkerArrayBytes()
        task = engine.scenario.task
        roles = {task.pick_up: "pick-up", task.drop_off: "drop-off", task.start_area: "start"}
        areas = areas_update(engine.world.areas, roles=roles)
        send(self._areas, MarkerArrayBytes().encode(areas, stamp=(now.sec, now.nanosec)))

    def publish(self, now: Time) -> None:
        """The people, the guest and (when it changed) the plan, as they are now."""
        navigator = self.engine.navigator
        plan = navigator.path if navigator.status == "running" else []
        update = self._tracker.update(self.engine.people_states(), plan)
        self._send(self._scene, self._encoder.encode(update, stamp=(now.sec, now.nanosec)))
