"""Navigation's costmap as a serialised ``nav_msgs/OccupancyGrid``, built without rclpy's copy.

The global costmap is about 126 000 cells. rclpy converts a message's ``int8[]`` element by
element, twice: its field setter checks every value and its serialiser copies them one at a
time (0.6 ms and 1.9 ms here, every sim second: a few per cent of the simulator's time). The
CDR encoding of an OccupancyGrid is fixed but for two lengths (the frame id and the data), so
this module writes it with :mod:`struct` around the cells' bytes, and the node hands the bytes
to ``Publisher.publish``, which sends serialised messages as they are. Readers cannot tell the
difference: ``tests/sim/test_costmap_message.py`` reads it back and compares it, field for field
and in length, with rclpy's own ``serialize_message``.

Costs become values by Nav2's ``Costmap2DPublisher`` table (free 0, inflated 1..252 scaled to
1..98, inscribed 99, lethal 100, unknown -1), looked up in one step. The costmap published is
its static layer with people marked on a few patches of it, so :class:`OccupancyValues` looks
the static layer up once and, each time, only the cells the people changed: looking up all
126 000 cells was about a third of the costmap's publishing.
"""

from __future__ import annotations

import struct

import numpy as np

from servicesim_sim.navigation.costmap import FREE, INSCRIBED, LETHAL, GridFrame

__all__ = ["OccupancyValues", "occupancy_values", "serialised_occupancy_grid"]

_ENCAPSULATION = b"\x00\x01\x00\x00"  # CDR, little endian
_TABLE = np.array([0, *(1 + (97 * (cost - 1)) // 251 for cost in range(1, INSCRIBED)), 99, 100,
                   -1], dtype=np.int8)
"""Nav2's value for each cost: free (0) 0, inflated 1..252 to 1..98, inscribed 99, lethal 100,
unknown (255) -1."""
assert _TABLE[FREE] == 0 and _TABLE[INSCRIBED] == 99 and _TABLE[LETHAL] == 100


def occupancy_values(costs: np.ndarray) -> np.ndarray:
    """Costs (0..255) as ``OccupancyGrid`` values, by Nav2's table."""
    return _TABLE[np.asarray(costs, dtype=np.uint8)]


class OccupancyValues:
    """Costs as ``OccupancyGrid`` values, for grids that differ from ``static`` in few cells."""

    def __init__(self, static: np.ndarray) -> None:
        self._static = np.ascontiguousarray(static, dtype=np.uint8)
        self._values = occupancy_values(self._static)

    def of(self, costs: np.ndarray) -> np.ndarray:
        """:func:`occupancy_values` of ``costs``; looked up only where they differ from the
        static costs (all of them if their shape does)."""
        costs = np.ascontiguousarray(costs, dtype=np.uint8)
        if costs.shape != self._static.shape:
            return occupancy_values(costs)
        flat = costs.ravel()
        changed = np.flatnonzero(flat != self._static.ravel())
        values = self._values.copy()
        values.ravel()[changed] = _TABLE[flat[changed]]
        return values


def serialised_occupancy_grid(values: np.ndarray, frame: GridFrame, *, frame_id: str,
                              stamp: tuple[int, int]) -> bytes:
    """The CDR bytes of an OccupancyGrid of ``values`` (int8, rows from the origin) laid out
    as ``frame`` says, stamped (sec, nanosec) in header and ``map_load_time`` alike."""
    body = bytearray()
    body += struct.pack("<iI", *stamp)
    _string(body, frame_id)
    _align(body, 4)
    body += struct.pack("<iIfII", stamp[0], stamp[1], frame.resolution, frame.cols, frame.rows)
    _align(body, 8)
    body += struct.pack("<7d", frame.origin_x, frame.origin_y, 0.0, 0.0, 0.0, 0.0, 1.0)
    cells = np.ascontiguousarray(values, dtype=np.int8)
    body += struct.pack("<I", cells.size)
    return _ENCAPSULATION + bytes(body) + cells.tobytes()


def _string(body: bytearray, text: str) -> None:
    encoded = text.encode() + b"\x00"
    _align(body, 4)
    body += struct.pack("<I", len(encoded)) + encoded


def _align(body: bytearray, size: int) -> None:
    body += b"\x00" * (-len(body) % size)
