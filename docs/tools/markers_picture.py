"""Draw what Foxglove's 3D panel shows of a run at one moment, from its ``run.mcap`` alone.

Used for ``docs/images/foxglove_markers.png``, where a screenshot of Foxglove cannot be taken:

    .venv/bin/python docs/tools/markers_picture.py RUN_DIR --at 60 \
        --out docs/images/foxglove_markers.png

The recording is read with rosbags (types from the schemas in the file) and the markers are
applied in order as a viewer applies them: ADD replaces the marker of the same namespace and
id, DELETE removes it, DELETEALL empties the namespace. The robot is placed by the transforms,
map -> odom -> base_footprint, seen from above.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Circle, Rectangle
from rosbags.highlevel import AnyReader

ADD, DELETE, DELETEALL = 0, 2, 3
CUBE, CYLINDER, LINE_STRIP, TEXT = 1, 3, 4, 9


def scene_at(path: Path, at_ns: int) -> tuple[Any, dict[tuple[str, int], Any], tuple[float, ...]]:
    """The map, the markers a viewer holds and the robot's (x, y, yaw) at ``at_ns``."""
    grid, markers, transforms = None, {}, {}
    with AnyReader([path]) as reader:
        for connection, log_time, data in reader.messages():
            if log_time > at_ns and grid is not None:
                break
            message = reader.deserialize(data, connection.msgtype)
            if connection.topic == "/servicebot/map":
                grid = message
            elif connection.topic.startswith("/servicesim/markers"):
                apply(markers, message.markers)
            elif connection.topic == "/tf":
                transforms.update({(t.header.frame_id, t.child_frame_id): t.transform
                                   for t in message.transforms})
    return grid, markers, robot_pose(transforms)


def apply(markers: dict[tuple[str, int], Any], received: list[Any]) -> None:
    for marker in received:
        if marker.action == DELETEALL:
            for key in [key for key in markers if key[0] == marker.ns]:
                del markers[key]
        elif marker.action == DELETE:
            markers.pop((marker.ns, marker.id), None)
        elif marker.action == ADD:
            markers[marker.ns, marker.id] = marker


def planar(transform: Any) -> tuple[float, float, float]:
    rotation = transform.rotation
    return (transform.translation.x, transform.translation.y,
            2.0 * math.atan2(rotation.z, rotation.w))


def robot_pose(transforms: dict[tuple[str, str], Any]) -> tuple[float, float, float]:
    mx, my, myaw = planar(transforms["map", "odom"])
    ox, oy, oyaw = planar(transforms["odom", "base_footprint"])
    return (mx + math.cos(myaw) * ox - math.sin(myaw) * oy,
            my + math.sin(myaw) * ox + math.cos(myaw) * oy, myaw + oyaw)


def draw(grid: Any, markers: dict[tuple[str, int], Any], robot: tuple[float, ...],
         out: Path, *, title: str) -> None:
    figure, axes = plt.subplots(figsize=(12, 6.4), dpi=110)
    figure.patch.set_facecolor("#15161c")
    axes.set_facecolor("#15161c")
    info = grid.info
    cells = np.asarray(grid.data, dtype=np.int16).reshape(info.height, info.width)
    image = np.where(cells > 50, 0.75, np.where(cells < 0, 0.12, 0.2))
    extent = (info.origin.position.x, info.origin.position.x + info.width * info.resolution,
              info.origin.position.y, info.origin.position.y + info.height * info.resolution)
    axes.imshow(image, origin="lower", extent=extent, cmap="gray", vmin=0, vmax=1)
    for marker in markers.values():
        draw_marker(axes, marker)
    x, y, yaw = robot
    axes.add_patch(Circle((x, y), 0.25, color="#ffd23f", zorder=5))
    axes.annotate("", xy=(x + 0.6 * math.cos(yaw), y + 0.6 * math.sin(yaw)), xytext=(x, y),
                  arrowprops={"arrowstyle": "->", "color": "#ffd23f", "lw": 2}, zorder=6)
    (row_low, col_low), (row_high, col_high) = (np.argwhere(cells == 0).min(axis=0),
                                                np.argwhere(cells == 0).max(axis=0))
    margin = 1.0
    axes.set_xlim(extent[0] + col_low * info.resolution - margin,
                  extent[0] + col_high * info.resolution + margin)
    axes.set_ylim(extent[2] + row_low * info.resolution - margin,
                  extent[2] + row_high * info.resolution + margin)
    axes.set_aspect("equal")
    axes.set_axis_off()
    axes.set_title(title, color="white", fontsize=10)
    figure.tight_layout()
    figure.savefig(out, facecolor=figure.get_facecolor())


def draw_marker(axes: Any, marker: Any) -> None:
    colour = (marker.color.r, marker.color.g, marker.color.b, marker.color.a)
    x, y = marker.pose.position.x, marker.pose.position.y
    if marker.type == CUBE:
        axes.add_patch(Rectangle((x - marker.scale.x / 2, y - marker.scale.y / 2),
                                 marker.scale.x, marker.scale.y, color=colour, zorder=1))
    elif marker.type == CYLINDER:
        axes.add_patch(Circle((x, y), marker.scale.x / 2, color=colour[:3], zorder=4))
    elif marker.type == LINE_STRIP:
        axes.plot([p.x for p in marker.points], [p.y for p in marker.points], color=colour,
                  linewidth=2, zorder=3)
    elif marker.type == TEXT:
        axes.text(x, y, marker.text, color="white", fontsize=5, ha="center", va="center",
                  zorder=7)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a run directory (holding run.mcap)")
    parser.add_argument("--at", type=float, required=True, help="sim seconds")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    grid, markers, robot = scene_at(args.run / "run.mcap", round(args.at * 1e9))
    draw(grid, markers, robot, args.out,
         title=f"run.mcap at {args.at:g} s sim: /servicebot/map, /servicesim/markers/areas, "
               "/servicesim/markers (people grey, guest blue, plan red), robot by /tf")


if __name__ == "__main__":
    main()
