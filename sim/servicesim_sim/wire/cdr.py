"""Templates of CDR bytes for messages serialised by hand (little-endian CDR, as Fast DDS
writes it on this machine).

Design intent: a message whose layout is fixed once its strings are known is written once,
constants and alignment included, with a zeroed slot for each group of numbers; encoding one
then copies the template and packs the numbers into their slots (:mod:`struct`), which costs a
fraction of building an rclpy message and letting ``Publisher.publish`` convert it. The users
(:mod:`servicesim_sim.wire.pose_messages`, :mod:`servicesim_sim.lockstep.message`,
:mod:`servicesim_sim.wire.marker_messages`) each have a test
that reads their bytes back with rclpy and compares them with rclpy's own serialisation.
"""

from __future__ import annotations

import struct

__all__ = ["ENCAPSULATION", "STAMP", "CdrTemplate"]

ENCAPSULATION = b"\x00\x01\x00\x00"
"""The serialised message's header: CDR, little endian."""
STAMP = struct.Struct("<iI")
"""``builtin_interfaces/Time``: sec, nanosec."""


class CdrTemplate:
    """A message's CDR bytes laid out once: constants written, number slots zeroed.

    Offsets count from the start of the message's bytes, encapsulation included; CDR aligns
    each primitive to its own size, counted from the end of the encapsulation. A template of
    one element of a sequence (:meth:`body`) starts where the element will: ``phase`` is that
    place's offset modulo 8 from the encapsulation's end.
    """

    def __init__(self, *, phase: int = 0) -> None:
        self._phase = phase
        self._body = bytearray()

    def slot(self, layout: struct.Struct, *, alignment: int) -> int:
        """Room for ``layout``'s numbers (zero until packed); its offset."""
        return self._append(bytes(layout.size), alignment=alignment)

    def pack(self, layout: struct.Struct, *values: object, alignment: int) -> int:
        """``values`` written by ``layout``; their offset."""
        return self._append(layout.pack(*values), alignment=alignment)

    def _append(self, data: bytes, *, alignment: int) -> int:
        if data:  # an empty array is not aligned
            self._align(alignment)
        offset = len(ENCAPSULATION) + len(self._body)
        self._body += data
        return offset

    def string(self, text: str) -> None:
        encoded = text.encode() + b"\x00"
        self._align(4)
        self._body += struct.pack("<I", len(encoded)) + encoded

    def count(self, number: int) -> None:
        """A sequence's length."""
        self._align(4)
        self._body += struct.pack("<I", number)

    def strings(self, texts: list[str]) -> None:
        """A ``string[]``: its length, then each string."""
        self.count(len(texts))
        for text in texts:
            self.string(text)

    def header(self, frame_id: str) -> int:
        """``std_msgs/Header``: the stamp's slot (its offset) and the frame's name."""
        offset = self.slot(STAMP, alignment=4)
        self.string(frame_id)
        return offset

    def done(self) -> bytes:
        return ENCAPSULATION + bytes(self._body)

    def body(self) -> bytes:
        """The bytes without the encapsulation: an element of a longer message."""
        return bytes(self._body)

    def _align(self, size: int) -> None:
        self._body += bytes(-(self._phase + len(self._body)) % size)
