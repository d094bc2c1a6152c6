"""The scene's ``MarkerArray`` as rclpy messages: the reference the simulator's hand-serialised
bytes (``servicesim_sim.wire.marker_messages``) are tested against, and what the marker tests
read as a viewer would. A DELETEALL per cleared namespace, the DELETEs, then the ADDs."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker, MarkerArray

from servicesim_sim.model.markers import Shape, Update
from servicesim_sim.wire.marker_messages import MAP_FRAME


def marker_array(update: Update, *, now: Time) -> MarkerArray:
    """The message the simulator's bytes for ``update`` must equal once serialised."""
    markers = [_bare(namespace, 0, Marker.DELETEALL, now) for namespace in update.clear]
    markers += [_bare(namespace, number, Marker.DELETE, now)
                for namespace, number in update.delete]
    markers += [_marker(shape, now) for shape in update.add]
    return MarkerArray(markers=markers)


def _bare(namespace: str, number: int, action: int, now: Time) -> Marker:
    marker = Marker(ns=namespace, id=number, action=action)
    marker.header.frame_id, marker.header.stamp = MAP_FRAME, now
    return marker


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
