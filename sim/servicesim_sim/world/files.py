"""World files: the map, the named target areas and the task a simulated world is made of.

A world file is a small YAML document (the format is described in
``docs/reference/worlds.md``). It names a standard ROS map_server map (a map YAML beside an
image), the target areas the referee's ``room_info`` service answers for, and optionally a
fixed task, the people counts, the drift schedule, the walkers' routes, AMCL's launch pose and
which areas a random task may use. :func:`load_world` reads and checks all of it and returns a
:class:`World`, an immutable value the engine, navigation and people share.

Design intent:

* The map follows map_server's semantics (as Nav2's ``map_io`` implements them) exactly, so any
  map a user made with ``map_saver`` or by hand loads and means the same thing it means to Nav2:
  ``trinary``, ``scale`` and ``raw`` modes, ``negate``, strict thresholds, alpha handling, and
  ``nav_msgs/OccupancyGrid`` row order (row 0 at the bottom, the image's last line).
* Every broken input is a :class:`WorldError` whose message is one line naming the file and the
  problem, so the command-line entry points can print it as it is and exit with status 2.
* The map grid is read-only: a world is shared between the parts of the simulator.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import yaml
from PIL import Image, UnidentifiedImageError

from servicesim_sim.world.distance import distance_to_blocked

FREE = 0
OCCUPIED = 100
UNKNOWN = -1
BLOCKED_FROM = 50  # cells of value 50..100 (and unknown) are obstacles; 0..49 are free
MAP_MODES = ("trinary", "scale", "raw")
DEFAULT_WORLD = Path(__file__).resolve().parents[1] / "worlds" / "office" / "world.yaml"
MAX_DRIFTS = 10_000  # drift.count: the original draws 30; a schedule is drawn one by one at start
MAX_WALKERS = 200
"""people.walkers at most: each walker's routes are planned at start, so the count sets how
long the simulator takes to come up. Setting the office in motion took 12.6 s with 200
walkers and 31.6 s with 400 on a busy 2-core machine
(``make_scenario`` and ``SimEngine``, seed 1; 1.6 s with the shipped 10), where a run gives its
simulator 60 s to come up: 200 keeps it within a fifth of that, with room for the idlers."""
MAX_IDLERS = 400
"""people.idlers at most: 400 idlers took 8.2 s to place on the office (no idling areas, no
walkers), measured as :data:`MAX_WALKERS` was; both at their bounds stay within half of the
60 s a run gives its simulator to come up."""
WORLD_KEYS = ("name", "description", "map", "areas", "task", "people", "idling_areas", "drift",
              "targets", "amcl_initial_pose", "walker_routes", "walkers")
AMCL_DEFAULT_INITIAL_POSE = (0.0, 0.0, 0.0)  # ROS 1 AMCL's initial_pose_x, _y, _a defaults


class WorldError(ValueError):
    """A world, map or area file that cannot be used; the message is one line."""


# --------------------------------------------------------------------------- values
@dataclass(frozen=True)
class AreaBox:
    """An axis-aligned target area in the world frame, metres."""

    min_x: float
    min_y: float
    max_x: float
    max_y: float

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """Whether ``(x, y)`` lies inside the box shrunk by ``margin`` on every side."""
        return (self.min_x + margin <= x <= self.max_x - margin
                and self.min_y + margin <= y <= self.max_y - margin)

    @property
    def centre(self) -> tuple[float, float]:
        return (self.min_x + self.max_x) / 2.0, (self.min_y + self.max_y) / 2.0

    @property
    def width(self) -> float:
        return self.max_x - self.min_x

    @property
    def height(self) -> float:
        return self.max_y - self.min_y


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """A static occupancy grid in ``nav_msgs/OccupancyGrid`` order.

    ``grid[row, col]`` holds 0 (free) .. 100 (occupied) or -1 (unknown); row 0 lies at
    ``origin_y`` and rows grow with +y, so ``grid.ravel()`` is the message's ``data``.
    ``origin_yaw`` is kept from the map file but, like much of ROS, ignored.
    """

    grid: np.ndarray
    resolution: float
    origin_x: float
    origin_y: float
    origin_yaw: float = 0.0

    @cached_property
    def width(self) -> int:
        return int(self.grid.shape[1])

    @cached_property
    def height(self) -> int:
        return int(self.grid.shape[0])

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """The ``(row, col)`` of the cell holding ``(x, y)``; it may be out of bounds."""
        return (math.floor((y - self.origin_y) / self.resolution),
                math.floor((x - self.origin_x) / self.resolution))

    def flat_index(self, x: float, y: float) -> int | None:
        """The index in ``grid.ravel()`` of the cell holding ``(x, y)`` (the cell
        :meth:`world_to_cell` gives), None off the map: for readers of a grid of the map's
        shape through a flat memoryview, which hands out Python floats without numpy scalars."""
        row = math.floor((y - self.origin_y) / self.resolution)
        col = math.floor((x - self.origin_x) / self.resolution)
        width = self.width
        if 0 <= row < self.height and 0 <= col < width:
            return row * width + col
        return None

    def cell_to_world(self, row: int, col: int) -> tuple[float, float]:
        """The world position of the centre of cell ``(row, col)``."""
        return (self.origin_x + (col + 0.5) * self.resolution,
                self.origin_y + (row + 0.5) * self.resolution)

    def in_bounds(self, row: int, col: int) -> bool:
        return 0 <= row < self.height and 0 <= col < self.width

    def blocked_mask(self) -> np.ndarray:
        """True where a cell is an obstacle: unknown, or occupied (value 50 or more)."""
        return (self.grid < FREE) | (self.grid >= BLOCKED_FROM)

    def free_mask(self) -> np.ndarray:
        """True where a cell is free: known and below 50."""
        return ~self.blocked_mask()

    @cached_property
    def wall_distance(self) -> np.ndarray:
        """Metres from each cell's centre to the nearest obstacle cell's centre (0 on one).

        Worked out once per map (a Euclidean distance transform over the free space's
        bounding box, :mod:`servicesim_sim.world.distance`: 15 ms of CPU on the office) and
        read-only: the robot's wall clearance and the scenario's free spots share it, as do
        the episodes a reset plays on the same world.
        """
        distance = distance_to_blocked(self.free_mask()) * self.resolution
        distance.setflags(write=False)
        return distance

    def is_free(self, x: float, y: float) -> bool:
        """Whether ``(x, y)`` lies on the map in a free cell."""
        row, col = self.world_to_cell(x, y)
        return self.in_bounds(row, col) and FREE <= int(self.grid[row, col]) < BLOCKED_FROM

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(min_x, min_y, max_x, max_y)`` of the whole grid, metres."""
        return (self.origin_x, self.origin_y,
                self.origin_x + self.width * self.resolution,
                self.origin_y + self.height * self.resolution)


@dataclass(frozen=True)
class TaskSpec:
    """A fixed task: who to fetch from where, where to take them, where the robot starts."""

    pick_up: str
    drop_off: str
    guest_name: str
    guest_x: float
    guest_y: float
    guest_yaw: float
    start_area: str
    start_x: float
    start_y: float
    start_yaw: float


@dataclass(frozen=True)
class IdlingArea:
    """A box where idlers stand, facing ``yaw`` (radians) give or take half a radian.

    ``min`` may equal ``max`` in x or y: a line of spots, as some of the original's areas are.
    """

    min_x: float
    min_y: float
    max_x: float
    max_y: float
    yaw: float


@dataclass(frozen=True)
class WalkerRoute:
    """A loop walkers walk, one way, waypoint to waypoint and back to the first; ``weight``:
    how many entries of the world's list of routes it is (a walker draws one entry)."""

    name: str
    weight: int
    waypoints: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class PlacedWalker:
    """A walker of the fixed task: its route, the waypoint it starts at and its speed."""

    route: str
    start: int
    speed: float


@dataclass(frozen=True)
class PeopleSpec:
    """How many people share the building with the robot and the guest, and how walkers wait.

    ``walker_patience_s``: a walker blocked this long turns back; infinite (the original's rule)
    means it waits as long as it stays blocked.
    """

    walkers: int = 10
    idlers: int = 30
    walker_patience_s: float = math.inf


@dataclass(frozen=True)
class DriftSpec:
    """When the guest drifts: first at ``start_s`` or later, then every min..max seconds;
    ``times``, when given, is the world's own fixed schedule for its fixed task (the shipped
    world file's), played when no seed draws one."""

    start_s: float = 200.0
    min_interval_s: float = 100.0
    max_interval_s: float = 300.0
    count: int = 30
    times: tuple[float, ...] | None = None


@dataclass(frozen=True)
class World:
    """A loaded, checked world: map, target areas (in file order) and task settings."""

    name: str
    path: Path
    map: OccupancyMap
    areas: dict[str, AreaBox]
    task: TaskSpec | None = None
    people: PeopleSpec = field(default_factory=PeopleSpec)
    drift: DriftSpec = field(default_factory=DriftSpec)
    targets: tuple[str, ...] = ()
    idling_areas: tuple[IdlingArea, ...] = ()  # none: idlers stand anywhere free
    # where AMCL starts before any initialpose, (x, y, yaw) in map; None: it waits for one
    amcl_initial_pose: tuple[float, float, float] | None = AMCL_DEFAULT_INITIAL_POSE
    walker_routes: tuple[WalkerRoute, ...] = ()  # none: each walker gets a random loop
    walkers: tuple[PlacedWalker, ...] = ()  # the fixed task's walkers; none: drawn


# --------------------------------------------------------------------------- reading YAML
class _UniqueKeyLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """A safe YAML loader that refuses a mapping naming the same key twice.

    libyaml's parser when PyYAML has it (its wheels do): the office's world file, read at every
    start of the simulator, takes 3 ms with it against 28 ms with the pure-Python one.
    """


def _construct_unique_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode) -> dict[Any, Any]:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    mapping: dict[Any, Any] = loader.construct_mapping(node, deep=True)
    return mapping


_UniqueKeyLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_unique_mapping)
_UniqueKeyLoader.add_implicit_resolver(  # YAML 1.2's 1e300: YAML 1.1 (PyYAML) read it as text
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


def _read_yaml(path: Path) -> Any:
    """The YAML document in ``path``; every failure is a one-line :class:`WorldError`."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise WorldError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise WorldError(f"{path}: is a directory, not a file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise WorldError(f"{path}: cannot read: {_one_line(str(error))}") from None
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)  # a SafeLoader: plain data only
    except yaml.YAMLError as error:
        raise WorldError(f"{path}: not valid YAML: {_yaml_problem(error)}") from None


def _yaml_problem(error: yaml.YAMLError) -> str:
    if isinstance(error, yaml.MarkedYAMLError):
        mark = error.problem_mark or error.context_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        return _one_line(f"{error.problem or error.context}{where}")
    return _one_line(str(error))


def _one_line(text: str) -> str:
    return " ".join(text.split())


class _Fields:
    """Typed access to one YAML mapping, failing with the file and the key's dotted path."""

    def __init__(self, data: Any, *, path: Path, where: str) -> None:
        self.path = path
        self.where = where
        if not isinstance(data, dict):
            self.fail(f"{where or 'the document'} must be a mapping, not {_kind(data)}")
        self.data: dict[Any, Any] = data

    def fail(self, problem: str) -> NoReturn:
        raise WorldError(f"{self.path}: {problem}")

    def name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def reject_unknown(self, allowed: tuple[str, ...]) -> None:
        for key in self.data:
            if key not in allowed:
                self.fail(f"unknown key {self.name(str(key))!r} (expected one of "
                          f"{', '.join(allowed)})")

    def has(self, key: str) -> bool:
        return key in self.data and self.data[key] is not None

    def raw(self, key: str) -> Any:
        if key not in self.data:
            self.fail(f"missing key {self.name(key)!r}")
        return self.data[key]

    def number(self, key: str, default: float | None = None) -> float:
        if default is not None and not self.has(key):
            return default
        return _as_number(self.raw(key), self, self.name(key))

    def integer(self, key: str, default: int | None = None) -> int:
        if default is not None and not self.has(key):
            return default
        value = self.raw(key)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(f"{self.name(key)} must be a whole number, not {_kind(value)}")
        return value

    def text(self, key: str, default: str | None = None) -> str:
        if default is not None and not self.has(key):
            return default
        value = self.raw(key)
        if not isinstance(value, str) or not value.strip():
            self.fail(f"{self.name(key)} must be a non-empty string, not {_kind(value)}")
        return value

    def child(self, key: str) -> _Fields:
        return _Fields(self.raw(key), path=self.path, where=self.name(key))


def _as_number(value: Any, fields: _Fields, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        fields.fail(f"{name} must be a number, not {_kind(value)}")
    if not math.isfinite(value):
        fields.fail(f"{name} must be a finite number, not {value}")
    return float(value)


def _kind(value: Any) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the text {value!r}" if len(value) <= 40 else "a long text"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)} item{'' if len(value) == 1 else 's'}"
    return f"{type(value).__name__} {value!r}"


# --------------------------------------------------------------------------- map files
@dataclass(frozen=True)
class MapFile:
    """The settings of a map_server map YAML."""

    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str = "trinary"


def read_map_file(path: str | Path) -> MapFile:
    """Parse and check a map_server map YAML (the image is resolved, not yet read)."""
    path = Path(path)
    fields = _Fields(_read_yaml(path), path=path, where="")
    image = fields.text("image")
    resolution = fields.number("resolution")
    if resolution <= 0.0:
        fields.fail(f"resolution must be more than 0, not {resolution:g}")
    origin = fields.raw("origin")
    if not isinstance(origin, list) or len(origin) not in (2, 3):
        fields.fail(f"origin must be a list [x, y, yaw], not {_kind(origin)}")
    origin_values = [_as_number(value, fields, "origin") for value in origin] + [0.0]
    occupied, free = fields.number("occupied_thresh"), fields.number("free_thresh")
    if not 0.0 <= free <= occupied <= 1.0:
        fields.fail(f"thresholds must satisfy 0 <= free_thresh ({free:g}) <= occupied_thresh "
                    f"({occupied:g}) <= 1")
    mode = fields.text("mode", default="trinary").lower()
    if mode not in MAP_MODES:
        fields.fail(f"mode must be one of {', '.join(MAP_MODES)}, not {fields.data['mode']!r}")
    return MapFile(image=path.parent / image, resolution=resolution,
                   origin=(origin_values[0], origin_values[1], origin_values[2]),
                   negate=_negate(fields), occupied_thresh=occupied, free_thresh=free, mode=mode)


def _negate(fields: _Fields) -> bool:
    value = fields.raw("negate")
    if isinstance(value, bool) or value in (0, 1):
        return bool(value)
    fields.fail(f"negate must be 0 or 1, not {_kind(value)}")


def load_map(path: str | Path) -> OccupancyMap:
    """Load a map_server map (its YAML and image) into an :class:`OccupancyMap`."""
    settings = read_map_file(path)
    grid = occupancy_from_pixels(_read_image(settings.image), settings=settings)
    grid.setflags(write=False)
    return OccupancyMap(grid=grid, resolution=settings.resolution, origin_x=settings.origin[0],
                        origin_y=settings.origin[1], origin_yaw=settings.origin[2])


@dataclass(frozen=True, eq=False)
class Pixels:
    """An image as map_server sees it, in image order (row 0 at the top), values in 0..1."""

    colour: np.ndarray  # (h, w): the mean of the colour channels (grey images: the grey)
    alpha: np.ndarray | None  # (h, w), 1 = opaque; None when the image has no alpha channel


def _read_image(path: Path) -> Pixels:
    try:
        with Image.open(path) as image:
            image.load()
            pixels = _pixels(image)
    except FileNotFoundError:
        raise WorldError(f"{path}: no such image file") from None
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, ValueError) as error:
        raise WorldError(f"{path}: cannot read the map image: {_one_line(str(error))}") from None
    if pixels.colour.size == 0:
        raise WorldError(f"{path}: the map image is empty")
    return pixels


def _pixels(image: Image.Image) -> Pixels:
    if image.mode == "L":  # 8-bit grey, as map_server's maps mostly are: no copy in colour
        grey = np.asarray(image, dtype=np.float64) / 255.0
        return Pixels(colour=(grey + grey + grey) / 3.0, alpha=None)  # as the mean of R, G, B
    if image.mode.startswith("I"):  # 16-bit grey (PGM with maxval > 255, 16-bit PNG)
        return Pixels(colour=np.asarray(image, dtype=np.float64) / 65535.0, alpha=None)
    if image.mode == "F":
        return Pixels(colour=np.clip(np.asarray(image, dtype=np.float64), 0.0, 1.0), alpha=None)
    has_alpha = "A" in image.getbands() or "transparency" in image.info
    values = np.asarray(image.convert("RGBA" if has_alpha else "RGB"), dtype=np.float64) / 255.0
    return Pixels(colour=values[:, :, :3].mean(axis=2),
                  alpha=values[:, :, 3] if has_alpha else None)


def occupancy_from_pixels(pixels: Pixels, *, settings: MapFile) -> np.ndarray:
    """map_server's rule per pixel: an int8 grid in OccupancyGrid order (row 0 at the bottom).

    Trinary: alpha (if any) is averaged in with the three colour channels; occupied when the
    occupancy exceeds ``occupied_thresh``, free below ``free_thresh``, else unknown.
    Scale: as trinary but in between scaled to 0..100, and any transparency means unknown.
    Raw: the pixel value 0..255 itself when it is 0..100, else unknown; ``negate`` is ignored.
    """
    shade = pixels.colour
    if settings.mode == "trinary" and pixels.alpha is not None:
        shade = (3.0 * pixels.colour + pixels.alpha) / 4.0
    grid = np.full(shade.shape, UNKNOWN, dtype=np.int8)
    if settings.mode == "raw":
        value = np.rint(shade * 255.0)
        inside = value <= OCCUPIED
        grid[inside] = value[inside].astype(np.int8)
        return np.flipud(grid).copy()
    occupancy = shade if settings.negate else 1.0 - shade
    if settings.mode == "scale":
        _scale_between(grid, occupancy, settings)
    grid[occupancy < settings.free_thresh] = FREE
    grid[occupancy > settings.occupied_thresh] = OCCUPIED
    if settings.mode == "scale" and pixels.alpha is not None:
        grid[pixels.alpha < 1.0] = UNKNOWN
    return np.flipud(grid).copy()


def _scale_between(grid: np.ndarray, occupancy: np.ndarray, settings: MapFile) -> None:
    span = settings.occupied_thresh - settings.free_thresh
    if span <= 0.0:
        return
    scaled = np.rint((occupancy - settings.free_thresh) / span * 100.0)
    between = (scaled >= FREE) & (scaled <= OCCUPIED)
    grid[between] = scaled[between].astype(np.int8)


# --------------------------------------------------------------------------- world files
def load_world(path: str | Path) -> World:
    """Read and check a world file and everything it names."""
    path = Path(path)
    fields = _Fields(_read_yaml(path), path=path, where="")
    fields.reject_unknown(WORLD_KEYS)
    if fields.has("description"):
        fields.text("description")
    occupancy = _world_map(fields)
    areas = _world_areas(fields, occupancy)
    task = _task(fields.child("task"), areas, occupancy) if fields.has("task") else None
    return World(
        name=fields.text("name", default=path.stem), path=path, map=occupancy, areas=areas,
        task=task, people=_people(fields), drift=_drift(fields),
        targets=_targets(fields, areas), idling_areas=_idling_areas(fields, occupancy),
        amcl_initial_pose=_amcl_initial_pose(fields), **_walkers(fields, occupancy),
    )


def _world_map(fields: _Fields) -> OccupancyMap:
    map_path = fields.path.parent / fields.text("map")
    try:
        return load_map(map_path)
    except WorldError as error:
        raise WorldError(f"{fields.path}: map {error}") from None


def _world_areas(fields: _Fields, occupancy: OccupancyMap) -> dict[str, AreaBox]:
    value = fields.raw("areas")
    if isinstance(value, str):
        return read_areas(fields.path.parent / value, occupancy=occupancy)
    return _areas(_Fields(value, path=fields.path, where="areas"), occupancy)


def read_areas(path: str | Path, *, occupancy: OccupancyMap | None = None) -> dict[str, AreaBox]:
    """Target areas from a file of their own: ``{Name: {min: [x, y], max: [x, y]}, ...}``.

    The whole document may also sit under one ``target_areas`` key.
    """
    path = Path(path)
    data = _read_yaml(path)
    where = ""
    if isinstance(data, dict) and list(data) == ["target_areas"]:
        data, where = data["target_areas"], "target_areas"
    return _areas(_Fields(data, path=path, where=where), occupancy)


def _areas(fields: _Fields, occupancy: OccupancyMap | None) -> dict[str, AreaBox]:
    if not fields.data:
        fields.fail(f"{fields.where or 'the area file'} names no target area")
    areas: dict[str, AreaBox] = {}
    for name in fields.data:
        if not isinstance(name, str) or not name.strip():
            fields.fail(f"area name {name!r} must be a non-empty string")
        areas[name] = _area(fields.child(name), occupancy)
    return areas


def _area(fields: _Fields, occupancy: OccupancyMap | None) -> AreaBox:
    fields.reject_unknown(("min", "max"))
    (min_x, min_y), (max_x, max_y) = _point(fields, "min"), _point(fields, "max")
    if not (min_x < max_x and min_y < max_y):
        fields.fail(f"{fields.where}: min ({min_x:g}, {min_y:g}) must be below max "
                    f"({max_x:g}, {max_y:g}) in both x and y")
    box = AreaBox(min_x=min_x, min_y=min_y, max_x=max_x, max_y=max_y)
    if occupancy is not None and not _box_on_map(box, occupancy):
        low_x, low_y, high_x, high_y = occupancy.extent
        fields.fail(f"{fields.where} lies outside the map (x {low_x:g}..{high_x:g}, "
                    f"y {low_y:g}..{high_y:g})")
    return box


def _walkers(fields: _Fields, occupancy: OccupancyMap) -> dict[str, Any]:
    """``walker_routes`` and the fixed task's ``walkers`` on them, checked together."""
    routes = _walker_routes(fields, occupancy)
    if not fields.has("walkers"):
        return {"walker_routes": routes, "walkers": ()}
    value = fields.raw("walkers")
    if not routes:
        fields.fail("walkers needs walker_routes to walk on")
    if not isinstance(value, list) or len(value) != _people(fields).walkers:
        fields.fail(f"walkers must be a list of people.walkers ({_people(fields).walkers}) "
                    f"walkers, not {_kind(value)}")
    by_name = {route.name: route for route in routes}
    walkers = tuple(_placed_walker(_Fields(item, path=fields.path, where=f"walkers[{index}]"),
                                   by_name) for index, item in enumerate(value))
    return {"walker_routes": routes, "walkers": walkers}


def _walker_routes(fields: _Fields, occupancy: OccupancyMap) -> tuple[WalkerRoute, ...]:
    if not fields.has("walker_routes"):
        return ()
    value = fields.raw("walker_routes")
    if not isinstance(value, list) or not value:
        fields.fail(f"walker_routes must be a non-empty list, not {_kind(value)}")
    routes = tuple(_walker_route(_Fields(item, path=fields.path, where=f"walker_routes[{index}]"),
                                 occupancy) for index, item in enumerate(value))
    names = [route.name for route in routes]
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        fields.fail(f"walker_routes names {duplicates[0]!r} twice")
    return routes


def _walker_route(fields: _Fields, occupancy: OccupancyMap) -> WalkerRoute:
    fields.reject_unknown(("name", "weight", "waypoints"))
    name, weight = fields.text("name"), fields.integer("weight", default=1)
    if weight < 1:
        fields.fail(f"{fields.name('weight')} must be 1 or more, not {weight}")
    value = fields.raw("waypoints")
    if not isinstance(value, list) or len(value) < 2:
        fields.fail(f"{fields.name('waypoints')} must be a list of at least two [x, y], "
                    f"not {_kind(value)}")
    waypoints = tuple(_waypoint(item, fields, f"{fields.name('waypoints')}[{index}]")
                      for index, item in enumerate(value))
    for x, y in waypoints:
        if not occupancy.is_free(x, y):
            fields.fail(f"{fields.where} waypoint ({x:g}, {y:g}) is not on a free map cell")
    return WalkerRoute(name=name, weight=weight, waypoints=waypoints)


def _waypoint(value: Any, fields: _Fields, name: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        fields.fail(f"{name} must be a list [x, y], not {_kind(value)}")
    return _as_number(value[0], fields, name), _as_number(value[1], fields, name)


def _placed_walker(fields: _Fields, routes: dict[str, WalkerRoute]) -> PlacedWalker:
    fields.reject_unknown(("route", "start", "speed"))
    name = fields.text("route")
    if name not in routes:
        fields.fail(f"{fields.name('route')} names an unknown walker route {name!r}")
    start, speed = fields.integer("start"), fields.number("speed")
    if not 0 <= start < len(routes[name].waypoints):
        fields.fail(f"{fields.name('start')} must be a waypoint of {name!r}, 0.."
                    f"{len(routes[name].waypoints) - 1}, not {start}")
    if not speed > 0.0:
        fields.fail(f"{fields.name('speed')} must be more than 0, not {speed:g}")
    return PlacedWalker(route=name, start=start, speed=speed)


def _amcl_initial_pose(fields: _Fields) -> tuple[float, float, float] | None:
    """``amcl_initial_pose``: absent, ROS 1 AMCL's default (0, 0, 0); null, none (AMCL waits
    for an initialpose, as Nav2's does by default); else ``[x, y, yaw]``."""
    if "amcl_initial_pose" not in fields.data:
        return AMCL_DEFAULT_INITIAL_POSE
    value = fields.data["amcl_initial_pose"]
    if value is None:
        return None
    if not isinstance(value, list) or len(value) != 3:
        fields.fail(f"amcl_initial_pose must be a list [x, y, yaw] or null, not {_kind(value)}")
    x, y, yaw = (_as_number(item, fields, "amcl_initial_pose") for item in value)
    return x, y, yaw


def _point(fields: _Fields, key: str) -> tuple[float, float]:
    value = fields.raw(key)
    if not isinstance(value, list) or len(value) != 2:
        fields.fail(f"{fields.name(key)} must be a list [x, y], not {_kind(value)}")
    return (_as_number(value[0], fields, fields.name(key)),
            _as_number(value[1], fields, fields.name(key)))


def _box_on_map(box: AreaBox, occupancy: OccupancyMap) -> bool:
    low_x, low_y, high_x, high_y = occupancy.extent
    return low_x <= box.min_x and box.max_x <= high_x and low_y <= box.min_y and box.max_y <= high_y


def _task(fields: _Fields, areas: dict[str, AreaBox], occupancy: OccupancyMap) -> TaskSpec:
    fields.reject_unknown(("pick_up", "drop_off", "guest", "start"))
    pick_up, drop_off = _area_name(fields, "pick_up", areas), _area_name(fields, "drop_off", areas)
    if pick_up == drop_off:
        fields.fail(f"task.pick_up and task.drop_off are both {pick_up!r}")
    guest, start = fields.child("guest"), fields.child("start")
    guest.reject_unknown(("name", "x", "y", "yaw"))
    start.reject_unknown(("area", "x", "y", "yaw"))
    start_area = _area_name(start, "area", areas)
    guest_x, guest_y = _pose_in(guest, areas[pick_up], pick_up, occupancy)
    start_x, start_y = _pose_in(start, areas[start_area], start_area, occupancy)
    return TaskSpec(pick_up=pick_up, drop_off=drop_off, guest_name=guest.text("name"),
                    guest_x=guest_x, guest_y=guest_y, guest_yaw=guest.number("yaw", default=0.0),
                    start_area=start_area, start_x=start_x, start_y=start_y,
                    start_yaw=start.number("yaw", default=0.0))


def _area_name(fields: _Fields, key: str, areas: dict[str, AreaBox]) -> str:
    name = fields.text(key)
    if name not in areas:
        fields.fail(f"{fields.name(key)} names an unknown area {name!r}")
    return name


def _pose_in(fields: _Fields, box: AreaBox, area: str,
             occupancy: OccupancyMap) -> tuple[float, float]:
    x, y = fields.number("x"), fields.number("y")
    if not box.contains(x, y):
        fields.fail(f"{fields.where} ({x:g}, {y:g}) lies outside its area {area!r}")
    if not occupancy.is_free(x, y):
        fields.fail(f"{fields.where} ({x:g}, {y:g}) is not on a free map cell")
    return x, y


def _people(fields: _Fields) -> PeopleSpec:
    if not fields.has("people"):
        return PeopleSpec()
    people = fields.child("people")
    people.reject_unknown(("walkers", "idlers", "walker_patience_s"))
    defaults = PeopleSpec()
    spec = PeopleSpec(walkers=people.integer("walkers", default=defaults.walkers),
                      idlers=people.integer("idlers", default=defaults.idlers),
                      walker_patience_s=people.number("walker_patience_s",
                                                      default=defaults.walker_patience_s))
    for key, count, most in (("walkers", spec.walkers, MAX_WALKERS),
                             ("idlers", spec.idlers, MAX_IDLERS)):
        if not 0 <= count <= most:
            people.fail(f"people.{key} must be within 0..{most}, not {count}")
    if not spec.walker_patience_s > 0.0:
        people.fail(f"people.walker_patience_s must be more than 0, not "
                    f"{spec.walker_patience_s:g}")
    return spec


def _idling_areas(fields: _Fields, occupancy: OccupancyMap) -> tuple[IdlingArea, ...]:
    if not fields.has("idling_areas"):
        return ()
    value = fields.raw("idling_areas")
    if not isinstance(value, list) or not value:
        fields.fail(f"idling_areas must be a non-empty list, not {_kind(value)}")
    return tuple(_idling_area(_Fields(item, path=fields.path, where=f"idling_areas[{index}]"),
                              occupancy) for index, item in enumerate(value))


def _idling_area(fields: _Fields, occupancy: OccupancyMap) -> IdlingArea:
    fields.reject_unknown(("min", "max", "yaw"))
    (min_x, min_y), (max_x, max_y) = _point(fields, "min"), _point(fields, "max")
    if not (min_x <= max_x and min_y <= max_y):
        fields.fail(f"{fields.where}: min ({min_x:g}, {min_y:g}) must not exceed max "
                    f"({max_x:g}, {max_y:g}) in x or y")
    if not _box_on_map(AreaBox(min_x, min_y, max_x, max_y), occupancy):
        fields.fail(f"{fields.where} lies outside the map")
    if not _has_free_cell(occupancy, min_x=min_x, min_y=min_y, max_x=max_x, max_y=max_y):
        fields.fail(f"{fields.where} has no free map cell for an idler to stand on")
    return IdlingArea(min_x=min_x, min_y=min_y, max_x=max_x, max_y=max_y,
                      yaw=fields.number("yaw"))


def _has_free_cell(occupancy: OccupancyMap, *, min_x: float, min_y: float, max_x: float,
                   max_y: float) -> bool:
    """Whether a free cell of ``occupancy`` overlaps the box."""
    low_row, low_col = occupancy.world_to_cell(min_x, min_y)
    high_row, high_col = occupancy.world_to_cell(max_x, max_y)
    rows = slice(max(low_row, 0), min(high_row, occupancy.height - 1) + 1)
    cols = slice(max(low_col, 0), min(high_col, occupancy.width - 1) + 1)
    cells = occupancy.grid[rows, cols]
    return bool(((cells >= FREE) & (cells < BLOCKED_FROM)).any())


def _drift(fields: _Fields) -> DriftSpec:
    if not fields.has("drift"):
        return DriftSpec()
    drift = fields.child("drift")
    drift.reject_unknown(("start_s", "min_interval_s", "max_interval_s", "count", "times"))
    defaults = DriftSpec()
    spec = DriftSpec(
        start_s=drift.number("start_s", default=defaults.start_s),
        min_interval_s=drift.number("min_interval_s", default=defaults.min_interval_s),
        max_interval_s=drift.number("max_interval_s", default=defaults.max_interval_s),
        count=drift.integer("count", default=defaults.count),
        times=_drift_times(drift),
    )
    _check_drift(drift, spec)
    return spec


def _drift_times(drift: _Fields) -> tuple[float, ...] | None:
    if not drift.has("times"):
        return None
    value = drift.raw("times")
    if not isinstance(value, list):
        drift.fail(f"drift.times must be a list of sim times in seconds, not {_kind(value)}")
    times = tuple(_as_number(time, drift, f"drift.times[{index}]")
                  for index, time in enumerate(value))
    if any(later <= earlier for earlier, later in itertools.pairwise(times)) or (
            times and times[0] < 0.0):
        drift.fail("drift.times must rise, from 0 or more")
    return times


def _check_drift(fields: _Fields, spec: DriftSpec) -> None:
    checks: tuple[tuple[bool, str], ...] = (
        (spec.start_s >= 0.0, f"drift.start_s must be 0 or more, not {spec.start_s:g}"),
        (spec.min_interval_s > 0.0,
         f"drift.min_interval_s must be more than 0, not {spec.min_interval_s:g}"),
        (spec.min_interval_s <= spec.max_interval_s,
         f"drift.min_interval_s ({spec.min_interval_s:g}) must not exceed drift.max_interval_s "
         f"({spec.max_interval_s:g})"),
        (0 <= spec.count <= MAX_DRIFTS,
         f"drift.count must be within 0..{MAX_DRIFTS}, not {spec.count}"),
    )
    for passed, problem in checks:
        if not passed:
            fields.fail(problem)


def _targets(fields: _Fields, areas: dict[str, AreaBox]) -> tuple[str, ...]:
    if not fields.has("targets"):
        return tuple(areas)
    value = fields.raw("targets")
    if not isinstance(value, list) or not value:
        fields.fail(f"targets must be a non-empty list of area names, not {_kind(value)}")
    for name in value:
        if not isinstance(name, str) or name not in areas:
            fields.fail(f"targets names an unknown area {name!r}")
    duplicates = sorted({name for name in value if value.count(name) > 1})
    if duplicates:
        fields.fail(f"targets names {duplicates[0]!r} twice")
    return tuple(value)
