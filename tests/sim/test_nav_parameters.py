"""The robot's navigation parameters: a Nav2 parameters file read, checked and obeyed.

The parser is tested on the texts themselves (every refusal names the file and the key); the
costmap is shown to follow what a file says: people inflated as walls are by default, and a
berth of their own from the shipped tree's file.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from servicesim_sim.arguments import build_parser
from servicesim_sim.nav_params import main as nav_params_main
from servicesim_sim.navigation.costmap import INSCRIBED, LETHAL, PERSON_RADIUS, Costmap, Lidar
from servicesim_sim.navigation.navigator import Navigator
from servicesim_sim.navigation.parameters import (
    REPLAN_EVERY_SECOND,
    REPLAN_WHEN_INVALID,
    SERVICEBOT,
    CostmapParameters,
    GoalChecker,
    InflationLayer,
    NavigationParameters,
    NavigationParametersError,
    inscribed_radius,
    load_navigation_parameters,
    parse_navigation_parameters,
)
from servicesim_sim.settings import SettingsError, navigation_from
from servicesim_sim.world.files import OccupancyMap

SHIPPED = Path(__file__).resolve().parents[2] / "trees" / "servicesim_nav2_params.yaml"
COSTMAP = "global_costmap:\n  global_costmap:\n    ros__parameters:\n"
MARK_AT_ANY_RANGE = Lidar(mark_range=30.0)


def parsed(text: str) -> NavigationParameters:
    return parse_navigation_parameters(text, source="mine.yaml")


def costmap_with(body: str) -> str:
    """A document whose global_costmap's ros__parameters are ``body`` (indented 6)."""
    return COSTMAP + "".join(f"      {line}\n" for line in body.splitlines())


def open_floor() -> OccupancyMap:
    """A 10 x 4 m room, walls one cell thick all round."""
    grid = np.zeros((80, 200), dtype=np.int8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 100
    return OccupancyMap(grid=grid, resolution=0.05, origin_x=0.0, origin_y=0.0)


# --------------------------------------------------------------------------- the default
def test_the_default_is_the_servicebots_move_base_configuration() -> None:
    costmap, checker = SERVICEBOT.costmap, SERVICEBOT.goal_checker
    assert costmap.inscribed_radius == pytest.approx(0.2)  # the 0.4 x 0.5 m footprint's
    servicebot = InflationLayer(inflation_radius=0.4, cost_scaling_factor=10.0)
    assert costmap.walls == (servicebot,) and costmap.people == (servicebot,)
    assert (checker.xy_goal_tolerance, checker.yaw_goal_tolerance) == (0.3, 0.262)
    assert SERVICEBOT.navigation_tree == REPLAN_WHEN_INVALID
    assert not SERVICEBOT.replans_every_second
    assert NavigationParameters() == SERVICEBOT and navigation_from(
        build_parser().parse_args([])) == SERVICEBOT


def test_a_file_that_names_only_some_keys_keeps_the_servicebots_other_values() -> None:
    tighter = parsed("controller_server:\n  ros__parameters:\n    general_goal_checker:\n"
                     "      xy_goal_tolerance: 0.2\n")
    assert tighter.costmap == SERVICEBOT.costmap
    assert tighter.goal_checker == GoalChecker(xy_goal_tolerance=0.2, yaw_goal_tolerance=0.262)
    wider = parsed(costmap_with("inflation_layer:\n  inflation_radius: 0.7"))
    assert wider.costmap.walls == wider.costmap.people == (InflationLayer(0.7, 10.0),)
    assert wider.costmap.inscribed_radius == SERVICEBOT.costmap.inscribed_radius


def test_the_shipped_trees_file_gives_people_a_berth_of_their_own() -> None:
    shipped = load_navigation_parameters(SHIPPED)
    assert shipped == NavigationParameters(
        costmap=CostmapParameters(inscribed_radius=0.25, walls=(InflationLayer(0.4, 5.0),),
                                  people=(InflationLayer(0.8, 2.5),)),
        goal_checker=GoalChecker(xy_goal_tolerance=0.3, yaw_goal_tolerance=0.262),
        navigation_tree=REPLAN_EVERY_SECOND)
    assert shipped.replans_every_second


@pytest.mark.parametrize("given", [
    REPLAN_EVERY_SECOND,
    "/opt/ros/kilted/share/nav2_bt_navigator/behavior_trees/" + REPLAN_EVERY_SECOND])
def test_the_navigation_tree_is_nav2s_file_by_name_or_by_path(given: str) -> None:
    chosen = parsed(f"bt_navigator:\n  ros__parameters:\n"
                    f"    default_nav_to_pose_bt_xml: {given!r}\n")
    assert chosen.navigation_tree == REPLAN_EVERY_SECOND and chosen.replans_every_second
    assert (chosen.costmap, chosen.goal_checker) == (SERVICEBOT.costmap, SERVICEBOT.goal_checker)
    named_default = parsed("bt_navigator:\n  ros__parameters:\n"
                           f"    default_nav_to_pose_bt_xml: {REPLAN_WHEN_INVALID}\n")
    assert named_default == SERVICEBOT


# --------------------------------------------------------------------------- layers in order
def test_an_inflation_layer_inflates_what_the_layers_before_it_marked() -> None:
    walls_only = parsed(costmap_with(
        'plugins: ["static_layer", "inflation_layer", "obstacle_layer"]\n'
        'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
        'inflation_layer: {plugin: "nav2_costmap_2d::InflationLayer"}\n'
        'obstacle_layer: {plugin: "nav2_costmap_2d::ObstacleLayer"}'))
    assert walls_only.costmap.walls == (InflationLayer(),) and walls_only.costmap.people == ()
    twice = parsed(costmap_with(
        'plugins: ["static_layer", "walls", "obstacle_layer", "both"]\n'
        'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
        'walls: {plugin: "nav2_costmap_2d::InflationLayer", inflation_radius: 0.5}\n'
        'obstacle_layer: {plugin: "nav2_costmap_2d::ObstacleLayer"}\n'
        'both: {plugin: "nav2_costmap_2d::InflationLayer", cost_scaling_factor: 3.0}'))
    assert twice.costmap.walls == (InflationLayer(0.5, 10.0), InflationLayer(0.4, 3.0))
    assert twice.costmap.people == (InflationLayer(0.4, 3.0),)


def test_a_disabled_layer_does_nothing() -> None:
    off = parsed(costmap_with("inflation_layer:\n  enabled: false"))
    assert off.costmap.walls == off.costmap.people == ()


def test_the_robot_is_its_footprints_inscribed_disc_or_its_radius() -> None:
    assert inscribed_radius(((0.3, 0.1), (0.3, -0.1), (-0.3, -0.1), (-0.3, 0.1))) == (
        pytest.approx(0.1))
    assert inscribed_radius(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0))) == 0.0  # centre outside
    assert parsed(costmap_with("robot_radius: 0.3")).costmap.inscribed_radius == 0.3
    footprint = parsed(costmap_with(
        'robot_radius: 0.3\nfootprint: "[[0.2, 0.15], [0.2, -0.15], [-0.2, -0.15], '
        '[-0.2, 0.15]]"'))
    assert footprint.costmap.inscribed_radius == pytest.approx(0.15)  # Nav2: footprint wins
    assert parsed(costmap_with('robot_radius: 0.3\nfootprint: "[]"')).costmap.inscribed_radius \
        == 0.3


# --------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(("text", "key", "problem"), [
    pytest.param("", "mine.yaml", "empty", id="empty"),
    pytest.param("global_costmap: [1, 2", "mine.yaml", "not YAML", id="not-yaml"),
    pytest.param("- 1\n- 2\n", "the document", "must be a mapping", id="not-a-mapping"),
    pytest.param("local_costmap: {}\n", "local_costmap", "not a parameter", id="unknown-node"),
    pytest.param("global_costmap:\n  ros__parameters: {}\n", "global_costmap.ros__parameters",
                 "not a parameter", id="costmap-not-nested"),
    pytest.param("global_costmap:\n  global_costmap: {}\n", "global_costmap.global_costmap",
                 "needs ros__parameters", id="no-ros-parameters"),
    pytest.param(costmap_with("update_frequency: 5.0"), "ros__parameters.update_frequency",
                 "not a parameter this simulator's navigation takes", id="unknown-key"),
    pytest.param(costmap_with("inflation_layer:\n  inflation_radius: 1"),
                 "inflation_layer.inflation_radius", "ROS 2 reads 1 as an integer; write 1.0",
                 id="integer-for-double"),
    pytest.param(costmap_with("inflation_layer:\n  cost_scaling_factor: high"),
                 "inflation_layer.cost_scaling_factor", "must be a double", id="text-for-double"),
    pytest.param(costmap_with("inflation_layer:\n  cost_scaling_factor: 0.0"),
                 "inflation_layer.cost_scaling_factor", "must be more than 0", id="zero-scaling"),
    pytest.param(costmap_with("inflation_layer:\n  inflation_radius: -0.1"),
                 "inflation_layer.inflation_radius", "must be at least 0", id="negative-radius"),
    pytest.param(costmap_with("inflation_layer:\n  inflation_radius: .nan"),
                 "inflation_layer.inflation_radius", "must be at least 0", id="nan"),
    pytest.param(costmap_with("inflation_layer:\n  enabled: 1"), "inflation_layer.enabled",
                 "must be true or false", id="integer-for-bool"),
    pytest.param(costmap_with("inflation_layer:\n  inflate_unknown: true"),
                 "inflation_layer.inflate_unknown", "not a parameter", id="unknown-layer-key"),
    pytest.param(costmap_with("robot_radius: 1.5"), "robot_radius", "at most 1",
                 id="huge-robot"),
    pytest.param(costmap_with('footprint: "[[0.2, 0.2], [0.2, -0.2]]"'), "footprint",
                 "at least 3 points", id="two-point-footprint"),
    pytest.param(costmap_with('footprint: "[[1.0, 1.0], [2.0, 1.0], [2.0, 2.0]]"'),
                 "footprint", "must lie inside the polygon", id="centre-outside-footprint"),
    pytest.param(costmap_with("footprint: [[0.2, 0.2], [0.2, -0.2], [-0.2, 0.0]]"), "footprint",
                 "must be a string", id="footprint-not-a-string"),
    pytest.param(costmap_with('footprint: "[]"'), "footprint", "no robot_radius",
                 id="no-robot-at-all"),
    pytest.param(costmap_with("plugins: []"), "plugins", "non-empty list", id="no-plugins"),
    pytest.param(costmap_with('plugins: ["static_layer", "static_layer"]'), "plugins",
                 "twice", id="plugin-twice"),
    pytest.param(costmap_with('plugins: ["static_layer", "obstacle_layer"]\n'
                              'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
                              "obstacle_layer: {}"), "obstacle_layer.plugin",
                 "missing: name the layer's type", id="untyped-layer"),
    pytest.param(costmap_with('plugins: ["static_layer", "social"]\n'
                              'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
                              'social: {plugin: "nav2_social_costmap_plugin::SocialLayer"}'),
                 "social.plugin", "not a layer this simulator's costmap has", id="unknown-layer"),
    pytest.param(costmap_with('inflation_layer: {plugin: "nav2_costmap_2d::ObstacleLayer"}'),
                 "inflation_layer.plugin", "is a nav2_costmap_2d::InflationLayer",
                 id="default-layer-retyped"),
    pytest.param(costmap_with('plugins: ["obstacle_layer", "static_layer"]\n'
                              'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
                              'obstacle_layer: {plugin: "nav2_costmap_2d::ObstacleLayer"}'),
                 "static_layer", "must be the first layer", id="static-not-first"),
    pytest.param(costmap_with('plugins: ["obstacle_layer"]\n'
                              'obstacle_layer: {plugin: "nav2_costmap_2d::ObstacleLayer"}'),
                 "plugins", "needs a nav2_costmap_2d::StaticLayer first", id="no-static"),
    pytest.param(costmap_with("obstacle_layer: {enabled: false}"), "plugins",
                 "feeds exactly one", id="no-obstacle-layer"),
    pytest.param(costmap_with('plugins: ["static_layer", "people"]\n'
                              'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
                              'people: {plugin: "nav2_costmap_2d::PluginContainerLayer"}'),
                 "people.plugins", "missing: name the container's layers", id="empty-container"),
    pytest.param(costmap_with("inflation_layer: 0.4"), "inflation_layer",
                 "must be a mapping", id="layer-not-a-mapping"),
    pytest.param("controller_server:\n  ros__parameters:\n    general_goal_checker:\n"
                 "      xy_goal_tolerance: 5.0\n", "general_goal_checker.xy_goal_tolerance",
                 "at most 2", id="huge-tolerance"),
    pytest.param("controller_server:\n  ros__parameters:\n    general_goal_checker:\n"
                 '      plugin: "nav2_controller::StoppedGoalChecker"\n',
                 "general_goal_checker.plugin", "checks goals as", id="other-goal-checker"),
    pytest.param("controller_server:\n  ros__parameters:\n    general_goal_checker:\n"
                 "      stateful: false\n", "general_goal_checker.stateful", "is stateful",
                 id="stateless"),
    pytest.param("controller_server:\n  ros__parameters:\n"
                 '    goal_checker_plugins: ["a", "b"]\n', "goal_checker_plugins",
                 "must name one goal checker", id="two-goal-checkers"),
    pytest.param("bt_navigator:\n  ros__parameters:\n"
                 "    default_nav_to_pose_bt_xml: navigate_w_replanning_time.xml\n",
                 "bt_navigator.ros__parameters.default_nav_to_pose_bt_xml",
                 "not a navigation tree this simulator's navigation plays", id="other-tree"),
    pytest.param("bt_navigator:\n  ros__parameters:\n    default_nav_to_pose_bt_xml: 3\n",
                 "default_nav_to_pose_bt_xml", "must be a string", id="tree-not-a-string"),
    pytest.param("bt_navigator:\n  ros__parameters:\n    navigators: [navigate_to_pose]\n",
                 "bt_navigator.ros__parameters.navigators", "not a parameter",
                 id="unknown-navigator-key"),
    pytest.param("controller_server:\n  ros__parameters:\n    FollowPath: {}\n",
                 "controller_server.ros__parameters.FollowPath", "not a parameter",
                 id="unknown-controller-key"),
])
def test_a_file_the_navigation_cannot_take_is_refused_naming_the_file_and_key(
        text: str, key: str, problem: str) -> None:
    with pytest.raises(NavigationParametersError) as refused:
        parsed(text)
    message = str(refused.value)
    assert message.startswith("mine.yaml: ") and "\n" not in message
    assert key in message and problem in message, message


def test_an_unreadable_file_is_one_line_through_the_simulators_settings(tmp_path: Path) -> None:
    arguments = build_parser().parse_args(["--nav-params", str(tmp_path / "missing.yaml")])
    with pytest.raises(SettingsError, match=r"^--nav-params .*missing\.yaml: No such file"):
        navigation_from(arguments)
    (tmp_path / "binary.yaml").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(NavigationParametersError, match="not a text file"):
        load_navigation_parameters(tmp_path / "binary.yaml")


def test_the_check_command_prints_what_a_file_means_or_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert nav_params_main([str(SHIPPED)]) == 0
    shipped = capsys.readouterr().out
    assert "people inflated: to 0.8 m, cost scaling 2.5" in shipped
    assert f"navigation tree: {REPLAN_EVERY_SECOND} (plans again every second)" in shipped
    assert nav_params_main([]) == 0
    default = capsys.readouterr().out
    assert "inscribed radius: 0.2 m" in default
    assert f"navigation tree: {REPLAN_WHEN_INVALID} (plans again when" in default
    (tmp_path / "bad.yaml").write_text(costmap_with("robot_radius: 2"))
    assert nav_params_main([str(tmp_path / "bad.yaml")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "bad.yaml: global_costmap.global_costmap.ros__parameters.robot_radius" in line


# --------------------------------------------------------------------------- the costmap obeys
def person_costs(parameters: NavigationParameters) -> tuple[Costmap, np.ndarray, list[int]]:
    """A person at (5.02, 2.02) seen by the lidar; the gaps from their edge to the centres of
    the cells east of them, 0.05 .. 1.15 m, and those cells' costs."""
    costmap = Costmap(open_floor(), layers=parameters.costmap, lidar=MARK_AT_ANY_RANGE)
    costmap.observe(2.0, 2.02, 0.0, [(5.02, 2.02)], now=1.0)
    row, col = costmap.frame.cell_of(5.02, 2.02)
    centres = [costmap.frame.centre_of(row, col + step) for step in range(4, 16)]
    gaps = np.array([math.hypot(x - 5.02, y - 2.02) - PERSON_RADIUS for x, y in centres])
    return costmap, gaps, [costmap.cost_at(x, y) for x, y in centres]


def test_by_default_people_are_inflated_as_walls_are_with_no_berth_of_their_own() -> None:
    costmap, gaps, costs = person_costs(SERVICEBOT)
    assert costmap.cost_at(5.02, 2.02) == LETHAL
    assert costs == costmap.inflation.costs(gaps).tolist(), "the walls' inflation, no other"
    beyond = [cost for gap, cost in zip(gaps, costs, strict=True) if gap > 0.4]
    assert len(beyond) >= 6 and not any(beyond), "nothing beyond the servicebot's 0.4 m"
    assert [cost for gap, cost in zip(gaps, costs, strict=True) if gap <= 0.2] == (
        [INSCRIBED] * int(np.sum(gaps <= 0.2)))  # the footprint's inscribed 0.2 m


def test_the_shipped_trees_file_keeps_a_berth_of_0_8_m_round_people_alone() -> None:
    costmap, gaps, costs = person_costs(load_navigation_parameters(SHIPPED))
    expected = [254 if gap <= 0.0 else 253 if gap <= 0.25 else
                round(max(252 * math.exp(-2.5 * (gap - 0.25)), 1.0)) if gap <= 0.8 else 0
                for gap in gaps]
    assert np.abs(np.subtract(costs, expected)).max() <= 1, (  # a rounding apart at most
        "Nav2's inflation from 0.25 m: 252 exp(-2.5 (d - 0.25)) out to 0.8 m")
    assert all(cost > 0 for gap, cost in zip(gaps, costs, strict=True) if gap <= 0.8)
    assert costmap.cost_at(0.05 + 0.6, 2.0) == 0, "walls keep their own 0.4 m inflation"


def test_the_navigator_takes_its_costmap_and_goal_checker_from_the_parameters() -> None:
    loose = NavigationParameters(goal_checker=GoalChecker(xy_goal_tolerance=1.0,
                                                          yaw_goal_tolerance=math.pi))
    navigator = Navigator(open_floor(), rng=np.random.default_rng(1), parameters=loose)
    assert navigator.costmap.layers == SERVICEBOT.costmap
    navigator.start(3.0, 2.0, math.pi, now=0.0)
    pose = (2.2, 2.0, 0.0)  # 0.8 m short, facing away: within both tolerances
    assert navigator.command(pose=pose, people=[], now=0.0) == (0.0, 0.0)
    assert navigator.status == "succeeded"
    strict = Navigator(open_floor(), rng=np.random.default_rng(1))
    strict.start(3.0, 2.0, math.pi, now=0.0)
    assert strict.command(pose=pose, people=[], now=0.0) != (0.0, 0.0)
    assert strict.status == "running"


def test_a_containers_people_are_inflated_by_its_own_layer_and_by_a_later_top_level_one() -> None:
    layered = parsed(costmap_with(
        'plugins: ["static_layer", "people", "inflation_layer"]\n'
        'static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}\n'
        "people:\n"
        '  plugin: "nav2_costmap_2d::PluginContainerLayer"\n'
        '  plugins: ["obstacle_layer", "inflation_layer"]\n'
        '  obstacle_layer: {plugin: "nav2_costmap_2d::ObstacleLayer"}\n'
        '  inflation_layer: {plugin: "nav2_costmap_2d::InflationLayer", '
        "inflation_radius: 0.9}\n"
        'inflation_layer: {plugin: "nav2_costmap_2d::InflationLayer"}'))
    assert layered.costmap.walls == (InflationLayer(),)
    assert layered.costmap.people == (InflationLayer(0.9, 10.0), InflationLayer())
