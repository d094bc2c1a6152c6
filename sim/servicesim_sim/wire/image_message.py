"""The front camera's frames as serialised ``sensor_msgs/Image`` messages.

A 640 x 480 rgb8 frame is 921 600 bytes. Building an rclpy ``Image`` of it and letting
``Publisher.publish`` convert it costs about 1.6 ms of CPU a frame (the message's constructor and
its copies of the pixels), 24 frames a sim second while the executive reads the camera: more
than rendering the frame. An Image's layout is fixed once its frame, size and encoding are, so
:class:`ImageBytes` lays it out once (:class:`~servicesim_sim.wire.cdr.CdrTemplate`) and each
frame packs its stamp and appends its pixels. ``tests/sim/test_image_message.py`` reads the
bytes back with rclpy and compares them with rclpy's own serialisation.
"""

from __future__ import annotations

import struct

import numpy as np

from servicesim_sim.wire.cdr import STAMP, CdrTemplate

__all__ = ["ImageBytes"]

_SIZE = struct.Struct("<II")  # height, width
_BIG_ENDIAN = struct.Struct("<B")
_STEP = struct.Struct("<I")


class ImageBytes:
    """Serialised ``sensor_msgs/Image`` messages of ``height`` x ``width`` rgb8 pixels in
    ``frame_id``."""

    def __init__(self, *, frame_id: str, height: int, width: int) -> None:
        self.height, self.width = height, width
        step = 3 * width
        template = CdrTemplate()
        self._stamp = template.header(frame_id)
        template.pack(_SIZE, height, width, alignment=4)
        template.string("rgb8")
        template.pack(_BIG_ENDIAN, 0, alignment=1)
        template.pack(_STEP, step, alignment=4)
        template.count(height * step)
        self._template = template.done()

    def encode(self, pixels: np.ndarray, *, stamp: tuple[int, int]) -> bytes:
        """The message of ``pixels`` (uint8, (height, width, 3)) stamped (sec, nanosec)."""
        if pixels.shape != (self.height, self.width, 3) or pixels.dtype != np.uint8:
            raise ValueError(f"pixels {pixels.shape} {pixels.dtype}: must be uint8 "
                             f"({self.height}, {self.width}, 3)")
        head = bytearray(self._template)
        STAMP.pack_into(head, self._stamp, *stamp)
        return b"".join((head, np.ascontiguousarray(pixels).data))
