"""The scene's ``visualization_msgs/MarkerArray``, serialised by hand: the bytes rclpy would
write for :func:`servicesim_sim.ros.marker_topics.marker_array` of the same update.

Design intent: the people are sent every 0.5 sim s and only where they stand changes, yet
building a ``Marker`` (rclpy checks every field it is set) and letting ``Publisher.publish``
convert and serialise the array cost the simulator about 6 % of its time. Here each marker is
a template of CDR bytes (:class:`MarkerBytes`): everything of it written once, with a slot for
the stamp and one for the position. The array copies the templates one after the other and
packs the numbers in. A template is kept per namespace and id and made again only when the
shape looks different (anything but its position). CDR aligns a ``float64`` to 8 bytes from
the end of the encapsulation, and a marker starts 4-aligned, so a marker has two layouts, one
per start modulo 8; each is made when first needed.

The layout follows ``visualization_msgs/msg/Marker`` field for field, the unused ones included
(``colors``, ``texture_resource``, ``texture``, ``uv_coordinates``, ``mesh_resource``,
``mesh_file``, ``mesh_use_embedded_materials``: empty). The alignment padding is zero, where
rclpy (Fast CDR) leaves whatever its buffer held; every other byte is rclpy's.
``tests/sim/test_marker_messages.py`` compares the bytes with rclpy's serialisation of
``marker_array`` and, byte for byte, with mcap_ros2's CDR writer of the same message.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from servicesim_sim.model.markers import Shape, Update
from servicesim_sim.wire.cdr import ENCAPSULATION, STAMP, CdrTemplate

__all__ = ["ADD", "DELETE", "DELETEALL", "MAP_FRAME", "MarkerArrayBytes", "MarkerBytes"]

MAP_FRAME = "map"
ADD, DELETE, DELETEALL = 0, 2, 3  # Marker's actions
_COUNT = struct.Struct("<I")
_NUMBERING = struct.Struct("<3i")  # id, type, action
_POSITION = struct.Struct("<3d")
_REST_OF_POSE = struct.Struct("<4d3d4f")  # orientation x y z w, scale x y z, colour r g b a
_LIFETIME_LOCKED = struct.Struct("<iI?")  # lifetime sec, nanosec; frame_locked
_FLAG = struct.Struct("<?")
_NO_POSITION = (0.0, 0.0, 0.0)

Look = tuple[object, ...]
"""Everything of a shape but its position; a marker's template is kept while it stays alike."""


@dataclass(frozen=True)
class MarkerBytes:
    """One marker's bytes for one phase: ``stamp`` and ``position`` are its slots' offsets."""

    data: bytes
    stamp: int
    position: int

    @classmethod
    def make(cls, *, namespace: str, number: int, action: int, phase: int,
             shape: Shape | None = None) -> MarkerBytes:
        """A marker as ``marker_array`` makes it: ``shape``'s for an ADD, else bare (a DELETE or
        DELETEALL: every other field at its default)."""
        writer = CdrTemplate(phase=phase)
        stamp = writer.pack(STAMP, 0, 0, alignment=4)
        writer.string(MAP_FRAME)
        writer.string(namespace)
        writer.pack(_NUMBERING, number, int(shape.kind) if shape else 0, action, alignment=4)
        position = writer.pack(_POSITION, *_NO_POSITION, alignment=8)
        scale, colour = (shape.scale, shape.colour) if shape else (_NO_POSITION, (0.0,) * 4)
        writer.pack(_REST_OF_POSE, 0.0, 0.0, 0.0, 1.0, *scale, *colour, alignment=8)
        writer.pack(_LIFETIME_LOCKED, 0, 0, False, alignment=4)
        _points(writer, shape)
        _tail(writer, text=shape.text if shape else "")
        at = len(ENCAPSULATION)  # the template's offsets count it; the element's do not
        return cls(data=writer.body(), stamp=stamp - at, position=position - at)


def _points(writer: CdrTemplate, shape: Shape | None) -> None:
    """``points`` (in the plane, at the shape's height), then ``colors``: none."""
    points = shape.points if shape else ()
    writer.count(len(points))
    numbers = [number for x, y in points for number in (x, y, shape.z)] if shape else []
    writer.pack(struct.Struct(f"<{len(numbers)}d"), *numbers, alignment=8)
    writer.count(0)


def _tail(writer: CdrTemplate, *, text: str) -> None:
    """From ``texture_resource`` to the end: all empty but ``text``."""
    writer.string("")  # texture_resource
    writer.pack(STAMP, 0, 0, alignment=4)  # texture: header stamp, frame, format, data
    writer.string("")
    writer.string("")
    writer.count(0)
    writer.count(0)  # uv_coordinates
    writer.string(text)
    writer.string("")  # mesh_resource
    writer.string("")  # mesh_file: filename, data
    writer.count(0)
    writer.pack(_FLAG, False, alignment=1)  # mesh_use_embedded_materials


def _look(shape: Shape) -> Look:
    return (shape.kind, shape.scale, shape.colour, shape.text, shape.points, shape.z)


class MarkerArrayBytes:
    """Encodes an :class:`~servicesim_sim.model.markers.Update` as a ``MarkerArray``'s CDR bytes,
    keeping each marker's templates (bounded by the namespaces and ids drawn)."""

    def __init__(self) -> None:
        self._shapes: dict[tuple[str, int, int], tuple[Look, MarkerBytes]] = {}
        self._bare: dict[tuple[str, int, int, int], MarkerBytes] = {}

    def encode(self, update: Update, *, stamp: tuple[int, int]) -> bytes:
        """``stamp``: (sec, nanosec) of every marker's header."""
        out = bytearray(ENCAPSULATION)
        out += _COUNT.pack(len(update.clear) + len(update.delete) + len(update.add))
        for namespace in update.clear:
            self._put(out, self._bare_marker(namespace, 0, DELETEALL, _phase(out)), stamp)
        for namespace, number in update.delete:
            self._put(out, self._bare_marker(namespace, number, DELETE, _phase(out)), stamp)
        for shape in update.add:
            self._put(out, self._shape_marker(shape, _phase(out)), stamp, shape.position)
        return bytes(out)

    @staticmethod
    def _put(out: bytearray, marker: MarkerBytes, stamp: tuple[int, int],
             position: tuple[float, float, float] = _NO_POSITION) -> None:
        out += bytes(-len(out) % 4)  # the encapsulation is 4 bytes: aligned alike
        start = len(out)
        out += marker.data
        STAMP.pack_into(out, start + marker.stamp, *stamp)
        _POSITION.pack_into(out, start + marker.position, *position)

    def _bare_marker(self, namespace: str, number: int, action: int, phase: int) -> MarkerBytes:
        key = (namespace, number, action, phase)
        marker = self._bare.get(key)
        if marker is None:
            marker = self._bare[key] = MarkerBytes.make(
                namespace=namespace, number=number, action=action, phase=phase)
        return marker

    def _shape_marker(self, shape: Shape, phase: int) -> MarkerBytes:
        key, look = (shape.namespace, shape.id, phase), _look(shape)
        kept = self._shapes.get(key)
        if kept is not None and kept[0] == look:
            return kept[1]
        marker = MarkerBytes.make(namespace=shape.namespace, number=shape.id, action=ADD,
                                  phase=phase, shape=shape)
        self._shapes[key] = (look, marker)
        return marker


def _phase(out: bytearray) -> int:
    """Where the next marker starts, modulo 8 from the encapsulation's end (4-aligned)."""
    return (len(out) - len(ENCAPSULATION) + 3) // 4 * 4 % 8
