"""A picture of a world: the map, every target area, the task and the people.

``python -m servicesim_sim.picture --world PATH --out PNG [--seed N]`` draws the building (walls
black, floor white, unknown grey), every target area with its name, the task the simulator
would play (the start area and pose as an arrow, the pick-up and drop-off areas highlighted, the
guest's spot) and the people where they stand when the simulator starts. Without ``--seed`` the
world's fixed task is drawn, with a seed the random task the simulator draws from that seed.

The drawing functions take a matplotlib ``Axes`` so other tools (a run replay, a report) can
reuse them: :func:`draw_map`, :func:`draw_areas`, :func:`draw_task` and :func:`draw_people`.
People and the task come from the simulator's own engine and scenario, so the picture shows
exactly what a run starts with.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NoReturn

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import FancyArrow, Patch, Rectangle

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.people import CrowdError
from servicesim_sim.model.scenario import ScenarioError, make_scenario
from servicesim_sim.world.files import (
    DEFAULT_WORLD,
    AreaBox,
    OccupancyMap,
    TaskSpec,
    World,
    WorldError,
    load_world,
)

PROG = "python -m servicesim_sim.picture"
FORMATS = (".png", ".svg", ".pdf")
METRES_PER_INCH = 2.4  # drawing scale: the office comes out about 20 x 10 inches
DPI = 150
MARGIN_M = 1.0
FREE_COLOUR, OCCUPIED_COLOUR, UNKNOWN_COLOUR = (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0.82, 0.82, 0.82)
AREA_COLOUR = "#4c72b0"
TASK_COLOURS = {"pick_up": "#2ca02c", "drop_off": "#ff7f0e", "start": "#1f77b4"}
PEOPLE_STYLES = {  # role: (marker, colour, size, legend label)
    "guest": ("*", "#d62728", 180, "guest"),
    "walker": ("^", "#9467bd", 40, "walker"),
    "idler": ("o", "#7f7f7f", 30, "idler"),
}


# --------------------------------------------------------------------------- drawing parts
def map_colours(occupancy: OccupancyMap) -> np.ndarray:
    """An RGB image of the grid (row 0 at the bottom): free white, occupied black, unknown grey.

    Cells between free and occupied (``scale`` maps) are shaded from white to black.
    """
    grid = occupancy.grid.astype(np.float64)
    shade = 1.0 - np.clip(grid, 0.0, 100.0) / 100.0
    image = np.repeat(shade[:, :, None], 3, axis=2)
    image[grid < 0] = UNKNOWN_COLOUR
    return image


def draw_map(axes: Axes, occupancy: OccupancyMap) -> None:
    """The occupancy grid in world coordinates."""
    low_x, low_y, high_x, high_y = occupancy.extent
    axes.imshow(map_colours(occupancy), origin="lower", extent=(low_x, high_x, low_y, high_y),
                interpolation="nearest", zorder=0)


def draw_areas(axes: Axes, areas: dict[str, AreaBox], *, font_size: float = 4.5) -> None:
    """Every target area as a translucent box labelled with its name."""
    for name, box in areas.items():
        axes.add_patch(Rectangle((box.min_x, box.min_y), box.width, box.height,
                                 facecolor=AREA_COLOUR, alpha=0.12, edgecolor=AREA_COLOUR,
                                 linewidth=0.6, zorder=1))
        axes.text(*box.centre, name, fontsize=font_size, ha="center", va="center",
                  rotation=90 if box.height > 1.5 * box.width else 0, color="#1a2a4a", zorder=4)


def draw_task(axes: Axes, task: TaskSpec, areas: dict[str, AreaBox]) -> None:
    """The pick-up, drop-off and start areas highlighted, the start pose and the guest spot."""
    for role, name in (("pick_up", task.pick_up), ("drop_off", task.drop_off),
                       ("start", task.start_area)):
        box = areas[name]
        axes.add_patch(Rectangle((box.min_x, box.min_y), box.width, box.height,
                                 facecolor=TASK_COLOURS[role], alpha=0.35,
                                 edgecolor=TASK_COLOURS[role], linewidth=2.0, zorder=2))
    length = 1.2
    axes.add_patch(FancyArrow(task.start_x, task.start_y, length * math.cos(task.start_yaw),
                              length * math.sin(task.start_yaw), width=0.12, head_width=0.45,
                              head_length=0.4, length_includes_head=True,
                              color=TASK_COLOURS["start"], zorder=5))
    axes.scatter([task.guest_x], [task.guest_y], marker="X", s=90, color=TASK_COLOURS["pick_up"],
                 edgecolors="black", linewidths=0.6, zorder=6)


def draw_people(axes: Axes, people: Iterable[tuple[str, str, float, float]]) -> None:
    """People as markers by role ("guest", "walker", "idler"); the guest is named."""
    by_role: dict[str, list[tuple[str, float, float]]] = {}
    for name, role, x, y in people:
        by_role.setdefault(role, []).append((name, x, y))
    for role, members in by_role.items():
        marker, colour, size, _ = PEOPLE_STYLES.get(role, ("s", "#17becf", 30, role))
        axes.scatter([x for _, x, _ in members], [y for _, _, y in members], marker=marker,
                     s=size, color=colour, edgecolors="black", linewidths=0.5, zorder=7)
        if role == "guest":
            for name, x, y in members:
                axes.annotate(name, (x, y), xytext=(6, 6), textcoords="offset points",
                              fontsize=7, color=colour, weight="bold", zorder=8)


def legend_handles(*, with_people: bool) -> list[Artist]:
    handles: list[Artist] = [Patch(facecolor=TASK_COLOURS[role], alpha=0.6, label=label)
               for role, label in (("pick_up", "pick-up area (X: guest spot)"),
                                   ("drop_off", "drop-off area"),
                                   ("start", "start area (arrow: start pose)"))]
    handles.append(Patch(facecolor=AREA_COLOUR, alpha=0.25, label="target area"))
    if with_people:
        handles += [Line2D([], [], linestyle="none", marker=marker, color=colour,
                           markeredgecolor="black", markersize=7, label=label)
                    for marker, colour, _, label in PEOPLE_STYLES.values()]
    return handles


# --------------------------------------------------------------------------- the whole picture
def known_extent(occupancy: OccupancyMap) -> tuple[float, float, float, float]:
    """``(min_x, min_y, max_x, max_y)`` around the known cells, with a margin."""
    rows, cols = np.nonzero(occupancy.grid >= 0)
    if rows.size == 0:
        return occupancy.extent
    low_x, low_y = occupancy.cell_to_world(int(rows.min()), int(cols.min()))
    high_x, high_y = occupancy.cell_to_world(int(rows.max()), int(cols.max()))
    return low_x - MARGIN_M, low_y - MARGIN_M, high_x + MARGIN_M, high_y + MARGIN_M


def draw_world(world: World, *, task: TaskSpec | None,
               people: Sequence[tuple[str, str, float, float]] | None) -> Figure:
    """A figure of ``world`` with ``task`` and ``people`` (either may be None: not drawn)."""
    low_x, low_y, high_x, high_y = known_extent(world.map)
    width, height = (high_x - low_x) / METRES_PER_INCH, (high_y - low_y) / METRES_PER_INCH
    figure = Figure(figsize=(width, height + 1.0), dpi=DPI)
    axes = figure.add_axes((0.03, 0.03, 0.94, 0.94 * height / (height + 1.0)))
    draw_map(axes, world.map)
    draw_areas(axes, world.areas)
    if task is not None:
        draw_task(axes, task, world.areas)
    if people is not None:
        draw_people(axes, people)
    axes.set_xlim(low_x, high_x)
    axes.set_ylim(low_y, high_y)
    axes.set_aspect("equal")
    axes.tick_params(labelsize=7)
    axes.set_xlabel("x (m)", fontsize=8)
    axes.set_ylabel("y (m)", fontsize=8)
    figure.suptitle(title(world, task), fontsize=11, y=0.985)
    figure.legend(handles=legend_handles(with_people=people is not None), loc="upper right",
                  fontsize=7, ncol=4, frameon=False, bbox_to_anchor=(0.97, 0.955))
    return figure


def title(world: World, task: TaskSpec | None) -> str:
    text = f"world {world.name}: {len(world.areas)} target areas"
    if task is not None:
        text += (f" | task: fetch {task.guest_name} from {task.pick_up} to {task.drop_off}, "
                 f"start in {task.start_area}")
    return text


def task_and_people(world: World, *, seed: int | None
                    ) -> tuple[TaskSpec, list[tuple[str, str, float, float]]]:
    """The task and people a simulator run on ``world`` starts with."""
    scenario = make_scenario(world, seed=seed)
    engine = SimEngine(world=world, scenario=scenario)
    return scenario.task, engine.people_states()


# --------------------------------------------------------------------------- command line
class OneLineArgumentParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description="Draw a world, its task and people.")
    parser.add_argument("--world", type=Path, default=DEFAULT_WORLD,
                        help="world file (default: the ServiceSim office)")
    parser.add_argument("--out", type=Path, required=True, help="image to write (.png/.svg/.pdf)")
    parser.add_argument("--seed", type=int, help="draw the random task of this seed "
                        "(default: the world's fixed task)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.seed is not None and args.seed < 0:
        parser.error(f"--seed {args.seed}: must be 0 or more")
    if args.out.suffix.lower() not in FORMATS:
        parser.error(f"--out {args.out}: the name must end in {', '.join(FORMATS)}")
    if not args.out.parent.is_dir():
        parser.error(f"--out {args.out}: no such directory {args.out.parent}")
    try:
        world = load_world(args.world)
        task, people = task_and_people(world, seed=args.seed)
    except (WorldError, ScenarioError) as error:
        parser.error(str(error))
    except CrowdError as error:
        parser.error(f"{args.world}: {error}")
    draw_world(world, task=task, people=people).savefig(args.out)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
