"""The robot's navigation parameters, read from a Nav2 parameters file, or the servicebot's.

Navigation belongs to the robot: each ServiceSim competitor configured move_base for the
servicebot, and a Nav2 user gives a parameters file. The simulator's navigation takes such a
file (``--nav-params FILE``), in Nav2's layout (``<node>: ros__parameters: ...``), with the
parameters a Nav2 stack really has, and only those the simulator's navigation models:

* ``global_costmap``'s robot (``robot_radius``, or a ``footprint`` polygon whose inscribed
  radius the planner keeps off obstacles, as Nav2's costmap computes it) and its layers
  (``plugins``): ``nav2_costmap_2d::StaticLayer`` (the walls), ``nav2_costmap_2d::ObstacleLayer``
  (the people the lidar marks), ``nav2_costmap_2d::InflationLayer`` (``inflation_radius``,
  ``cost_scaling_factor``) and ``nav2_costmap_2d::PluginContainerLayer``, which keeps layers of
  its own: an obstacle layer and an inflation layer in a container inflate the people alone,
  the way Nav2 gives "different inflation layers for different sensors";
* ``controller_server``'s goal checker (``nav2_controller::SimpleGoalChecker``:
  ``xy_goal_tolerance``, ``yaw_goal_tolerance``);
* ``bt_navigator``'s ``default_nav_to_pose_bt_xml``: when the robot plans its path again. Nav2
  ships its navigation trees as XML files; the simulator's navigation models two of them by
  name (a path ending in the name, as Nav2 users give it, or the name alone):
  ``navigate_w_replanning_only_if_path_becomes_invalid.xml``, the default, plans again once
  people stand on the path (and every few seconds for a clearly shorter way), near what
  move_base does with its default ``planner_frequency`` of 0, which the servicebot kept (plan
  once, again when the way is blocked); ``navigate_to_pose_w_replanning_and_recovery.xml``,
  Nav2's own default, plans again every second and follows the new path (unless it is much
  longer than what is left of the current one), so a berth the costmap keeps round people
  holds while they move and stop.

Design intent:

* Without a file the robot is the original's servicebot, as its move_base was configured
  (``competitor_example_solution/servicebot_2dnav/config/*.yaml``): footprint 0.4 x 0.5 m,
  inflation 0.4 m with move_base's default cost scaling 10, people inflated as walls are (one
  inflation layer after the obstacle layer), goal tolerance 0.3 m and 0.262 rad. A file sets
  what it names; whatever it leaves out keeps the servicebot's value.
* Layers act as Nav2's do on the master grid, in order: an inflation layer inflates the
  obstacles the layers before it put there (the walls, the people, or both); a container's
  inflation layer inflates only what its own layers marked, and what the container marked is
  on the costmap for the layers after it. :class:`CostmapParameters` keeps
  the result: which inflations the walls get and which the people get.
* A file is checked whole before anything starts: an unknown key, a key of the wrong type
  (ROS 2 reads ``10`` as an integer and refuses it for a double: write ``10.0``) or a value out
  of range is a :class:`NavigationParametersError`, one line naming the file and the key.
* The referee, the people and the rules are not the robot's: nothing here reaches them.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

STATIC_LAYER = "nav2_costmap_2d::StaticLayer"
OBSTACLE_LAYER = "nav2_costmap_2d::ObstacleLayer"
INFLATION_LAYER = "nav2_costmap_2d::InflationLayer"
CONTAINER_LAYER = "nav2_costmap_2d::PluginContainerLayer"
GOAL_CHECKER = "nav2_controller::SimpleGoalChecker"
REPLAN_WHEN_INVALID = "navigate_w_replanning_only_if_path_becomes_invalid.xml"
"""Nav2's navigation tree that plans again only when the path becomes invalid: the default."""
REPLAN_EVERY_SECOND = "navigate_to_pose_w_replanning_and_recovery.xml"
"""Nav2's default navigation tree: it plans again every second (a ``RateController`` of 1 Hz
round ``ComputePathToPose``) and follows the new path."""
NAVIGATION_TREES = (REPLAN_WHEN_INVALID, REPLAN_EVERY_SECOND)
ROS_PARAMETERS = "ros__parameters"

# The servicebot's configuration (competitor_example_solution/servicebot_2dnav/config/).
SERVICEBOT_FOOTPRINT = ((0.2, 0.25), (0.2, -0.25), (-0.2, -0.25), (-0.2, 0.25))
"""``costmap_common_params.yaml`` line 2."""
SERVICEBOT_INFLATION_RADIUS = 0.4
"""``global_costmap_params.yaml`` line 7, ``local_costmap_params.yaml`` line 7."""
SERVICEBOT_COST_SCALING_FACTOR = 10.0
"""Not set by the servicebot: move_base's (and Nav2's) default."""
SERVICEBOT_XY_GOAL_TOLERANCE = 0.3
"""``base_local_planner_params.yaml``, ``xy_goal_tolerance``."""
SERVICEBOT_YAW_GOAL_TOLERANCE = 0.262
"""``base_local_planner_params.yaml``, ``yaw_goal_tolerance``."""
SERVICEBOT_LAYERS = ("static_layer", "obstacle_layer", "inflation_layer")
"""move_base's layers for a costmap with ``static_map: true`` and an observation source:
static, obstacles, inflation, in that order."""
DEFAULT_GOAL_CHECKER = "general_goal_checker"

RADIUS_RANGE = (0.0, 1.0)  # metres: more than 0
INFLATION_RADIUS_RANGE = (0.0, 5.0)  # metres: 0 or more
COST_SCALING_RANGE = (0.0, 100.0)  # per metre: more than 0
XY_TOLERANCE_RANGE = (0.05, 2.0)  # metres
YAW_TOLERANCE_RANGE = (0.01, math.pi)  # radians


class NavigationParametersError(ValueError):
    """A parameters file the simulator's navigation cannot take; the message is one line."""


def inscribed_radius(footprint: tuple[tuple[float, float], ...]) -> float:
    """The distance from the robot's centre to the nearest edge of its footprint polygon (as
    Nav2's ``calculateMinAndMaxDistances``); 0 when the centre is not inside it."""
    nearest = math.inf
    crossings = 0
    for (x0, y0), (x1, y1) in zip(footprint, footprint[1:] + footprint[:1], strict=True):
        dx, dy = x1 - x0, y1 - y0
        square = dx * dx + dy * dy
        t = 0.0 if square == 0.0 else min(max(-(x0 * dx + y0 * dy) / square, 0.0), 1.0)
        nearest = min(nearest, math.hypot(x0 + t * dx, y0 + t * dy))
        if (y0 > 0.0) != (y1 > 0.0) and x0 + (0.0 - y0) * dx / dy > 0.0:
            crossings += 1
    return nearest if crossings % 2 == 1 else 0.0


SERVICEBOT_INSCRIBED_RADIUS = inscribed_radius(SERVICEBOT_FOOTPRINT)
"""0.2 m: the planner keeps the robot's centre this far from obstacles."""


@dataclass(frozen=True)
class InflationLayer:
    """One ``nav2_costmap_2d::InflationLayer``: costs fall from 252 at the inscribed radius
    as ``252 exp(-cost_scaling_factor (d - inscribed))`` out to ``inflation_radius``."""

    inflation_radius: float = SERVICEBOT_INFLATION_RADIUS
    cost_scaling_factor: float = SERVICEBOT_COST_SCALING_FACTOR


@dataclass(frozen=True)
class CostmapParameters:
    """The costmap as its layers make it: the robot's inscribed radius, and the inflation
    layers that inflate the walls and those that inflate the people (none: lethal where they
    are, nothing around)."""

    inscribed_radius: float = SERVICEBOT_INSCRIBED_RADIUS
    walls: tuple[InflationLayer, ...] = (InflationLayer(),)
    people: tuple[InflationLayer, ...] = (InflationLayer(),)


@dataclass(frozen=True)
class GoalChecker:
    """``nav2_controller::SimpleGoalChecker``'s tolerances."""

    xy_goal_tolerance: float = SERVICEBOT_XY_GOAL_TOLERANCE
    yaw_goal_tolerance: float = SERVICEBOT_YAW_GOAL_TOLERANCE


@dataclass(frozen=True)
class NavigationParameters:
    """Everything the robot's navigation is told; the defaults are the servicebot's."""

    costmap: CostmapParameters = field(default_factory=CostmapParameters)
    goal_checker: GoalChecker = field(default_factory=GoalChecker)
    navigation_tree: str = REPLAN_WHEN_INVALID
    """Which of :data:`NAVIGATION_TREES` the navigation plays (``bt_navigator``'s
    ``default_nav_to_pose_bt_xml``, by its file name)."""

    @property
    def replans_every_second(self) -> bool:
        """Whether the path is planned again every second, as Nav2's default tree does."""
        return self.navigation_tree == REPLAN_EVERY_SECOND


SERVICEBOT = NavigationParameters()


# --------------------------------------------------------------------------- reading a file
def load_navigation_parameters(path: str | Path) -> NavigationParameters:
    """The parameters a file gives, over the servicebot's; a
    :class:`NavigationParametersError` naming the file and the key otherwise."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise NavigationParametersError(f"{path}: {error.strerror or error}") from error
    except UnicodeDecodeError as error:
        raise NavigationParametersError(f"{path}: not a text file ({error.reason})") from error
    return parse_navigation_parameters(text, source=str(path))


def parse_navigation_parameters(text: str, *, source: str) -> NavigationParameters:
    """:func:`load_navigation_parameters` of a file's text; ``source`` names it in errors."""
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        problem = getattr(error, "problem", None) or "cannot be read"
        raise NavigationParametersError(f"{source}: not YAML: {problem}{where}") from None
    return _Reader(source).document(document)


class _Reader:
    """Walks a parameters document, naming every key it refuses by its dotted path."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, problem: str) -> NavigationParametersError:
        return NavigationParametersError(f"{self.source}: {key}: {problem}")

    def mapping(self, value: object, key: str) -> Mapping[str, Any]:
        if not isinstance(value, dict) or not all(isinstance(name, str) for name in value):
            raise self.fail(key, "must be a mapping of parameter names")
        return value

    def only(self, values: Mapping[str, Any], key: str, allowed: tuple[str, ...]) -> None:
        for name in values:
            if name not in allowed:
                raise self.fail(f"{key}.{name}" if key else name,
                                f"not a parameter this simulator's navigation takes "
                                f"(it takes {', '.join(allowed)})")

    def document(self, document: object) -> NavigationParameters:
        if document is None:
            raise NavigationParametersError(f"{self.source}: empty; name a node's "
                                            f"{ROS_PARAMETERS} (global_costmap, "
                                            "controller_server, bt_navigator)")
        top = self.mapping(document, "the document")
        self.only(top, "", ("global_costmap", "controller_server", "bt_navigator"))
        costmap = SERVICEBOT.costmap
        if "global_costmap" in top:
            inner = self.mapping(top["global_costmap"], "global_costmap")
            self.only(inner, "global_costmap", ("global_costmap",))
            key = "global_costmap.global_costmap"
            costmap = self.costmap(self.parameters(inner.get("global_costmap"), key),
                                   f"{key}.{ROS_PARAMETERS}")
        goal_checker = SERVICEBOT.goal_checker
        if "controller_server" in top:
            goal_checker = self.controller(
                self.parameters(top["controller_server"], "controller_server"),
                f"controller_server.{ROS_PARAMETERS}")
        navigation_tree = SERVICEBOT.navigation_tree
        if "bt_navigator" in top:
            navigation_tree = self.navigator(
                self.parameters(top["bt_navigator"], "bt_navigator"),
                f"bt_navigator.{ROS_PARAMETERS}")
        return NavigationParameters(costmap=costmap, goal_checker=goal_checker,
                                    navigation_tree=navigation_tree)

    def parameters(self, node: object, key: str) -> Mapping[str, Any]:
        values = self.mapping(node, key)
        self.only(values, key, (ROS_PARAMETERS,))
        if ROS_PARAMETERS not in values:
            raise self.fail(key, f"needs {ROS_PARAMETERS}")
        return self.mapping(values[ROS_PARAMETERS], f"{key}.{ROS_PARAMETERS}")

    # ------------------------------------------------------------------ typed values
    def double(self, values: Mapping[str, Any], key: str, name: str, default: float,
               bounds: tuple[float, float], *, low_open: bool = False) -> float:
        if name not in values:
            return default
        value = values[name]
        where = f"{key}.{name}"
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(where, f"must be a double, not {value!r}")
        if isinstance(value, int):
            raise self.fail(where, f"must be a double: ROS 2 reads {value} as an integer; "
                                   f"write {value}.0")
        low, high = bounds
        if not (math.isfinite(value) and (value > low if low_open else value >= low)
                and value <= high):
            side = "more than" if low_open else "at least"
            raise self.fail(where, f"{value}: must be {side} {low:g} and at most {high:g}")
        return float(value)

    def string(self, values: Mapping[str, Any], key: str, name: str) -> str | None:
        if name not in values:
            return None
        if not isinstance(values[name], str):
            raise self.fail(f"{key}.{name}", f"must be a string, not {values[name]!r}")
        return str(values[name])

    def names(self, values: Mapping[str, Any], key: str, name: str) -> tuple[str, ...] | None:
        if name not in values:
            return None
        names = values[name]
        if not (isinstance(names, list) and names
                and all(isinstance(entry, str) and entry for entry in names)):
            raise self.fail(f"{key}.{name}", "must be a non-empty list of names")
        if len(set(names)) != len(names):
            raise self.fail(f"{key}.{name}", "names a layer twice")
        return tuple(names)

    def boolean(self, values: Mapping[str, Any], key: str, name: str, default: bool) -> bool:
        if name not in values:
            return default
        if not isinstance(values[name], bool):
            raise self.fail(f"{key}.{name}", f"must be true or false, not {values[name]!r}")
        return bool(values[name])

    # ------------------------------------------------------------------ global_costmap
    def costmap(self, values: Mapping[str, Any], key: str) -> CostmapParameters:
        given = self.names(values, key, "plugins")
        plugins = given or SERVICEBOT_LAYERS
        self.only(values, key, ("robot_radius", "footprint", "plugins", *plugins))
        layers = _Layers(self, require_types=given is not None)
        layers.walk(values, key, plugins, top=True)
        if layers.obstacle_layers != 1:
            raise self.fail(f"{key}.plugins", f"names {layers.obstacle_layers} enabled "
                                              f"{OBSTACLE_LAYER}s; the simulator's lidar "
                                              "feeds exactly one")
        return CostmapParameters(inscribed_radius=self.robot(values, key),
                                 walls=tuple(layers.inflations["walls"]),
                                 people=tuple(layers.inflations["people"]))

    def robot(self, values: Mapping[str, Any], key: str) -> float:
        """The inscribed radius: the footprint's if it names one (as Nav2: a footprint other
        than ``[]`` wins over ``robot_radius``), else the robot radius, else the servicebot's."""
        radius = (self.double(values, key, "robot_radius", 0.0, RADIUS_RANGE, low_open=True)
                  if "robot_radius" in values else None)
        text = self.string(values, key, "footprint")
        footprint = None if text is None else self.footprint(text, f"{key}.footprint")
        if footprint:
            return inscribed_radius(footprint)
        if radius is not None:
            return radius
        if text is not None:
            raise self.fail(f"{key}.footprint", "is [] and no robot_radius is given")
        return SERVICEBOT.costmap.inscribed_radius

    def footprint(self, text: str, key: str) -> tuple[tuple[float, float], ...]:
        try:
            points = json.loads(text)
        except ValueError:
            points = None
        if not (isinstance(points, list) and all(
                isinstance(point, list) and len(point) == 2
                and all(isinstance(c, (int, float)) and not isinstance(c, bool)
                        and math.isfinite(c) and abs(c) <= 2.0 for c in point)
                for point in points)) or len(points) in (1, 2):
            raise self.fail(key, f"{text!r}: must be \"[]\" or a polygon of at least 3 "
                                 "points, \"[[x, y], ...]\", each within 2 m of the centre")
        polygon = tuple((float(x), float(y)) for x, y in points)
        if polygon and not RADIUS_RANGE[0] < inscribed_radius(polygon) <= RADIUS_RANGE[1]:
            raise self.fail(key, f"{text!r}: the robot's centre must lie inside the polygon")
        return polygon

    # ------------------------------------------------------------------ controller_server
    def controller(self, values: Mapping[str, Any], key: str) -> GoalChecker:
        names = self.names(values, key, "goal_checker_plugins") or (DEFAULT_GOAL_CHECKER,)
        if len(names) != 1:
            raise self.fail(f"{key}.goal_checker_plugins",
                            "must name one goal checker: the simulator's navigation has one")
        checker = names[0]
        self.only(values, key, ("goal_checker_plugins", checker))
        if checker not in values:
            return SERVICEBOT.goal_checker
        where = f"{key}.{checker}"
        section = self.mapping(values[checker], where)
        self.only(section, where, ("plugin", "xy_goal_tolerance", "yaw_goal_tolerance",
                                   "stateful"))
        plugin = self.string(section, where, "plugin")
        if plugin is not None and plugin != GOAL_CHECKER:
            raise self.fail(f"{where}.plugin", f"{plugin!r}: the simulator's navigation checks "
                                               f"goals as {GOAL_CHECKER}")
        if not self.boolean(section, where, "stateful", True):
            raise self.fail(f"{where}.stateful", "the simulator's goal checker is stateful "
                                                 "(the servicebot's latch_xy_goal_tolerance)")
        default = SERVICEBOT.goal_checker
        return GoalChecker(
            xy_goal_tolerance=self.double(section, where, "xy_goal_tolerance",
                                          default.xy_goal_tolerance, XY_TOLERANCE_RANGE),
            yaw_goal_tolerance=self.double(section, where, "yaw_goal_tolerance",
                                           default.yaw_goal_tolerance, YAW_TOLERANCE_RANGE))


    # ------------------------------------------------------------------ bt_navigator
    def navigator(self, values: Mapping[str, Any], key: str) -> str:
        """The navigation tree's file name, one of :data:`NAVIGATION_TREES`."""
        name = "default_nav_to_pose_bt_xml"
        self.only(values, key, (name,))
        path = self.string(values, key, name)
        if path is None:
            return SERVICEBOT.navigation_tree
        tree = path.rsplit("/", 1)[-1]
        if tree not in NAVIGATION_TREES:
            raise self.fail(f"{key}.{name}", f"{path!r}: not a navigation tree this "
                            f"simulator's navigation plays (it plays Nav2's "
                            f"{' and '.join(NAVIGATION_TREES)})")
        return tree


_DEFAULT_TYPES = dict(zip(SERVICEBOT_LAYERS, (STATIC_LAYER, OBSTACLE_LAYER, INFLATION_LAYER),
                          strict=True))


class _Layers:
    """The layers in Nav2's order, and what each inflation layer inflates."""

    def __init__(self, reader: _Reader, *, require_types: bool) -> None:
        self.reader = reader
        self.require_types = require_types
        self.obstacle_layers = 0
        self.inflations: dict[str, list[InflationLayer]] = {"walls": [], "people": []}

    def walk(self, values: Mapping[str, Any], key: str, plugins: tuple[str, ...], *,
             top: bool) -> list[str]:
        """Each layer in order; what they marked (``walls``, ``people``) on this grid."""
        marked: list[str] = []  # what the layers so far put on this grid
        for index, name in enumerate(plugins):
            where = f"{key}.{name}"
            section = self.reader.mapping(values.get(name, {}), where)
            kind = self.kind(section, where, name)
            if kind == STATIC_LAYER:
                self.static(section, where, marked, top=top, index=index)
            elif kind == OBSTACLE_LAYER:
                self.obstacles(section, where, marked)
            elif kind == INFLATION_LAYER:
                self.inflation(section, where, marked)
            else:  # what the container marked is on this grid for the layers after it
                marked += self.container(section, where, top=top)
        if top and "walls" not in marked:
            raise self.reader.fail(f"{key}.plugins", f"needs a {STATIC_LAYER} first: the "
                                                     "map's walls")
        return marked

    def kind(self, section: Mapping[str, Any], where: str, name: str) -> str:
        plugin = self.reader.string(section, where, "plugin")
        if plugin is None:
            if self.require_types or name not in _DEFAULT_TYPES:
                raise self.reader.fail(f"{where}.plugin", "missing: name the layer's type")
            return _DEFAULT_TYPES[name]
        if plugin not in (STATIC_LAYER, OBSTACLE_LAYER, INFLATION_LAYER, CONTAINER_LAYER):
            raise self.reader.fail(f"{where}.plugin", f"{plugin!r}: not a layer this "
                                   f"simulator's costmap has (it has {STATIC_LAYER}, "
                                   f"{OBSTACLE_LAYER}, {INFLATION_LAYER}, {CONTAINER_LAYER})")
        if not self.require_types and name in _DEFAULT_TYPES and plugin != _DEFAULT_TYPES[name]:
            raise self.reader.fail(f"{where}.plugin", f"{plugin!r}: {name} is a "
                                   f"{_DEFAULT_TYPES[name]}; give plugins to lay out others")
        return plugin

    def enabled(self, section: Mapping[str, Any], where: str, allowed: tuple[str, ...]) -> bool:
        self.reader.only(section, where, ("plugin", "enabled", *allowed))
        return self.reader.boolean(section, where, "enabled", True)

    def static(self, section: Mapping[str, Any], where: str, marked: list[str], *,
               top: bool, index: int) -> None:
        if not self.enabled(section, where, ()) or not top or index != 0:
            raise self.reader.fail(where, f"the {STATIC_LAYER} (the map's walls) must be the "
                                          "first layer of global_costmap, and enabled")
        marked.append("walls")

    def obstacles(self, section: Mapping[str, Any], where: str, marked: list[str]) -> None:
        if self.enabled(section, where, ()):
            self.obstacle_layers += 1
            marked.append("people")

    def inflation(self, section: Mapping[str, Any], where: str, marked: list[str]) -> None:
        if not self.enabled(section, where, ("inflation_radius", "cost_scaling_factor")):
            return
        read = self.reader.double
        layer = InflationLayer(
            inflation_radius=read(section, where, "inflation_radius",
                                  SERVICEBOT_INFLATION_RADIUS, INFLATION_RADIUS_RANGE),
            cost_scaling_factor=read(section, where, "cost_scaling_factor",
                                     SERVICEBOT_COST_SCALING_FACTOR, COST_SCALING_RANGE,
                                     low_open=True))
        for source in marked:
            self.inflations[source].append(layer)

    def container(self, section: Mapping[str, Any], where: str, *, top: bool) -> list[str]:
        """The container's layers walked on a grid of their own; what they marked."""
        if not top:
            raise self.reader.fail(where, f"a {CONTAINER_LAYER} inside another is not taken")
        plugins = self.reader.names(section, where, "plugins")
        if plugins is None:
            raise self.reader.fail(f"{where}.plugins", "missing: name the container's layers")
        if not self.enabled(section, where, ("plugins", *plugins)):
            return []
        require_types, self.require_types = self.require_types, True
        marked = self.walk(section, where, plugins, top=False)
        self.require_types = require_types
        return marked
