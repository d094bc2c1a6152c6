"""The costmap's message, serialised by hand: what rclpy would send, field for field.

Not byte for byte: Fast CDR leaves alignment padding as it found the buffer, so rclpy's own
bytes differ from run to run there; ours pad with zeros."""

from __future__ import annotations

import numpy as np
import pytest
from nav_msgs.msg import OccupancyGrid
from rclpy.serialization import deserialize_message, serialize_message

from servicesim_sim.navigation.costmap import FREE, INSCRIBED, LETHAL, MAX_INFLATED, GridFrame
from servicesim_sim.wire.costmap_message import (
    OccupancyValues,
    occupancy_values,
    serialised_occupancy_grid,
)


def by_rclpy(values: np.ndarray, frame: GridFrame, frame_id: str,
             stamp: tuple[int, int]) -> bytes:
    message = OccupancyGrid()
    message.header.frame_id = frame_id
    message.header.stamp.sec, message.header.stamp.nanosec = stamp
    message.info.map_load_time = message.header.stamp
    message.info.resolution = frame.resolution
    message.info.width, message.info.height = frame.cols, frame.rows
    message.info.origin.position.x = frame.origin_x
    message.info.origin.position.y = frame.origin_y
    message.info.origin.orientation.w = 1.0
    message.data = values.ravel().tolist()
    return serialize_message(message)


@pytest.mark.parametrize("frame_id", ["map", "odom", "", "a_longer_frame"])
@pytest.mark.parametrize(("rows", "cols"), [(3, 5), (247, 509), (1, 1)])
def test_the_bytes_are_rclpys_own(frame_id: str, rows: int, cols: int) -> None:
    values = np.random.default_rng(rows * cols).integers(-1, 101, size=(rows, cols),
                                                         dtype=np.int8)
    frame = GridFrame(origin_x=-28.65, origin_y=-1.1, resolution=0.1, rows=rows, cols=cols)
    ours = serialised_occupancy_grid(values, frame, frame_id=frame_id, stamp=(1234, 500_000_000))
    theirs = by_rclpy(values, frame, frame_id, (1234, 500_000_000))
    assert len(ours) == len(theirs)
    read, expected = (deserialize_message(data, OccupancyGrid) for data in (ours, theirs))
    assert read == expected
    assert (read.info.width, read.info.height, read.header.frame_id) == (cols, rows, frame_id)
    assert np.asarray(read.data, dtype=np.int8).reshape(rows, cols).tolist() == values.tolist()


def test_costs_translate_to_occupancy_values_by_nav2s_table() -> None:
    costs = np.array([FREE, 1, 126, MAX_INFLATED, INSCRIBED, LETHAL, 255], dtype=np.uint8)
    assert occupancy_values(costs).tolist() == [0, 1, 49, 98, 99, 100, -1]


@pytest.mark.parametrize("changes", [0, 1, 50, 5000, 247 * 509])
def test_values_from_the_static_grid_are_the_tables_own(changes: int) -> None:
    rng = np.random.default_rng(changes)
    static = rng.integers(0, 256, size=(247, 509), dtype=np.uint8)
    values = OccupancyValues(static)
    costs = static.copy()
    cells = rng.choice(costs.size, size=changes, replace=False)
    costs.ravel()[cells] = rng.integers(0, 256, size=changes, dtype=np.uint8)
    ours = values.of(costs)
    assert ours.dtype == np.int8 and ours.shape == costs.shape
    assert ours.tolist() == occupancy_values(costs).tolist()
    assert values.of(static).tolist() == occupancy_values(static).tolist()  # nothing kept


def test_values_of_a_grid_of_another_shape_are_looked_up_whole() -> None:
    values = OccupancyValues(np.zeros((3, 4), dtype=np.uint8))
    costs = np.array([[FREE, 1, 126], [MAX_INFLATED, INSCRIBED, 255]], dtype=np.uint8)
    assert values.of(costs).tolist() == [[0, 1, 49], [98, 99, -1]]
