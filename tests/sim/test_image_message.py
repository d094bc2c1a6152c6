"""The camera's frames, serialised by hand: what rclpy would send, field for field.

Not byte for byte: Fast CDR leaves alignment padding as it found the buffer, so rclpy's own
bytes may differ there; ours pad with zeros."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import Image

from servicesim_sim.wire.image_message import ImageBytes


def by_rclpy(pixels: np.ndarray, frame_id: str, stamp: tuple[int, int]) -> bytes:
    image = Image(height=pixels.shape[0], width=pixels.shape[1], encoding="rgb8",
                  is_bigendian=0, step=pixels.shape[1] * 3)
    image.header.stamp.sec, image.header.stamp.nanosec = stamp
    image.header.frame_id = frame_id
    image.data = pixels.tobytes()
    return serialize_message(image)


@pytest.mark.parametrize("frame_id", ["camera_front", "", "a_longer_frame_name"])
@pytest.mark.parametrize(("height", "width"), [(480, 640), (3, 5), (1, 1), (2, 62)])
def test_the_bytes_are_rclpys_own(frame_id: str, height: int, width: int) -> None:
    pixels = np.random.default_rng(height * width).integers(0, 256, size=(height, width, 3),
                                                            dtype=np.uint8)
    ours = ImageBytes(frame_id=frame_id, height=height, width=width).encode(
        pixels, stamp=(1234, 500_000_000))
    theirs = by_rclpy(pixels, frame_id, (1234, 500_000_000))
    assert len(ours) == len(theirs)
    read, expected = (deserialize_message(data, Image) for data in (ours, theirs))
    assert read == expected
    assert bytes(read.data) == pixels.tobytes()


def test_a_frame_of_another_size_is_refused() -> None:
    with pytest.raises(ValueError, match="must be uint8"):
        ImageBytes(frame_id="camera_front", height=4, width=4).encode(
            np.zeros((4, 5, 3), dtype=np.uint8), stamp=(0, 0))
