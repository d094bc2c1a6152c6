"""The robot's pose as a real robot gives it: odometry from zero at the spawn pose, an AMCL-like
map estimate after an initial pose, the transforms on /tf, and the lidar's LaserScan.

The models are tested directly (no ROS); one test reads them over DDS from the node."""

from __future__ import annotations

import math
from collections.abc import Iterator
from functools import cache
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from servicesim_sim.model.engine import NavigationState, SimEngine
from servicesim_sim.model.localisation import (
    CONVERGENCE_RADIUS_M,
    AmclModel,
    WheelOdometry,
    between,
    compose,
    inverse,
)
from servicesim_sim.model.scan import LidarSpec, Scanner
from servicesim_sim.model.scenario import Difficulty, make_scenario
from servicesim_sim.ros.node import LATCHED, SimulatorNode
from servicesim_sim.settings import SimSettings
from servicesim_sim.world.files import DEFAULT_WORLD, World, load_world
from tests.sim.test_node import Graph

SPAWN = (10.975, 3.75, 3.14)  # the shipped task's start pose: far from the origin, facing west


@cache
def office() -> World:
    return load_world(DEFAULT_WORLD)


def engine(difficulty: Difficulty | None = None, seed: int | None = None) -> SimEngine:
    return SimEngine(world=office(), scenario=make_scenario(office(), seed=seed,
                                                            difficulty=difficulty))


def drive(sim: SimEngine, v: float, w: float, seconds: float) -> None:
    for _ in range(round(seconds / sim.dt)):
        sim.command_velocity(v, w)
        sim.step()


def close(a: tuple[float, ...], b: tuple[float, ...], tolerance: float = 1e-6) -> bool:
    return (math.dist(a[:2], b[:2]) <= tolerance
            and abs(math.remainder(a[2] - b[2], math.tau)) <= tolerance)


# ------------------------------------------------------------------ the transforms
def test_composing_with_the_inverse_gives_the_identity_and_between_undoes_compose() -> None:
    a, b = (3.0, -2.0, 2.5), (-1.0, 4.0, -0.7)
    assert close(compose(a, inverse(a)), (0.0, 0.0, 0.0))
    assert close(between(a, compose(a, b)), b)
    assert close(compose((1.0, 2.0, math.pi / 2), (1.0, 0.0, 0.0)), (1.0, 3.0, math.pi / 2))


# ------------------------------------------------------------------ odometry
def test_odometry_starts_at_zero_at_the_spawn_pose_and_follows_the_motion() -> None:
    sim = engine()
    assert sim.robot_pose() == SPAWN
    assert sim.odometry_pose() == (0.0, 0.0, 0.0)
    drive(sim, 0.5, 0.0, 1.0)  # one second straight ahead: west in the map
    x, y, _ = sim.odometry_pose()
    assert x == pytest.approx(0.5, abs=1e-6) and y == pytest.approx(0.0, abs=1e-6)
    assert sim.robot_pose()[0] == pytest.approx(SPAWN[0] - 0.5, abs=1e-2)
    assert close(compose(SPAWN, sim.odometry_pose()), sim.robot_pose())


def test_odometry_drift_wanders_off_the_true_motion_and_is_the_same_for_a_seed() -> None:
    def odometry_after_a_loop(drift: float, seed: int) -> tuple[float, float, float]:
        odometry = WheelOdometry(drift=drift, rng=np.random.default_rng(seed))
        for _ in range(200):
            odometry.update(v=0.5, w=0.2, dt=0.1)
        return odometry.pose

    exact = odometry_after_a_loop(0.0, 1)
    assert close(compose(SPAWN, exact), compose(SPAWN, odometry_after_a_loop(0.0, 2)))
    drifted = odometry_after_a_loop(0.05, 1)
    assert math.dist(drifted[:2], exact[:2]) > 0.05
    assert drifted == odometry_after_a_loop(0.05, 1)


def test_a_negative_drift_or_noise_is_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="drift -1"):
        WheelOdometry(drift=-1.0, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="noise -1"):
        AmclModel(noise=-1.0, rng=np.random.default_rng(0))


# ------------------------------------------------------------------ localisation
def test_nothing_is_localised_until_an_initial_pose_which_is_then_the_estimate() -> None:
    sim = engine()
    drive(sim, 0.5, 0.0, 1.0)
    assert sim.estimated_pose() is None and sim.new_estimate() is None
    guess = (SPAWN[0] - 0.3, SPAWN[1] + 0.2, SPAWN[2])
    sim.set_initial_pose(*guess)
    estimate = sim.new_estimate()
    assert estimate is not None and estimate.pose == guess
    assert close(sim.estimated_pose() or (), guess)
    assert close(compose(sim.map_to_odom(), sim.odometry_pose()), guess)
    assert sim.new_estimate() is None  # published once


def test_a_near_guess_converges_to_the_truth_at_the_first_update_past_the_thresholds() -> None:
    sim = engine()
    sim.set_initial_pose(SPAWN[0] + 0.6, SPAWN[1] - 0.4, SPAWN[2] + 0.3)
    sim.new_estimate()
    drive(sim, 0.5, 0.0, 0.4)  # 0.2 m: under update_min_d, no update yet
    assert sim.new_estimate() is None
    assert not close(sim.estimated_pose() or (), sim.robot_pose(), 0.1)
    drive(sim, 0.5, 0.0, 0.2)  # 0.3 m in all
    assert sim.new_estimate() is not None  # published at 0.25 m, the truth then
    assert close(sim.estimated_pose() or (), sim.robot_pose(), 0.02)


def test_a_turn_past_update_min_a_updates_the_filter_too() -> None:
    sim = engine()
    sim.set_initial_pose(*SPAWN)
    sim.new_estimate()
    drive(sim, 0.0, 1.0, 0.25)  # 0.25 rad on the spot
    assert sim.new_estimate() is not None


def test_a_guess_beyond_the_convergence_radius_stays_off_as_odometry_carries_it() -> None:
    sim = engine()
    guess = (SPAWN[0] - 2.0 * CONVERGENCE_RADIUS_M, SPAWN[1], SPAWN[2])
    sim.set_initial_pose(*guess)
    drive(sim, 0.5, 0.0, 2.0)
    estimate = sim.new_estimate()
    assert estimate is not None  # the filter updated, and is still lost
    assert math.dist(estimate.pose[:2], sim.robot_pose()[:2]) == pytest.approx(
        2.0 * CONVERGENCE_RADIUS_M, abs=0.05)


def test_localisation_noise_puts_the_estimate_off_by_about_that_much_for_a_seed() -> None:
    def error(seed: int) -> float:
        sim = engine(Difficulty(localisation_noise=0.2), seed=seed)
        sim.set_initial_pose(*sim.robot_pose())
        drive(sim, 0.5, 0.0, 1.0)
        return math.dist((sim.estimated_pose() or ())[:2], sim.robot_pose()[:2])

    assert 0.0 < error(3) < 1.0
    assert error(3) == error(3)


def test_odometry_drift_is_corrected_by_localisation_at_each_update() -> None:
    sim = engine(Difficulty(odom_drift=0.1), seed=4)
    sim.set_initial_pose(*sim.robot_pose())
    drive(sim, 0.5, 0.3, 8.0)
    truth = sim.robot_pose()
    start = sim.scenario.task
    dead_reckoned = compose((start.start_x, start.start_y, start.start_yaw), sim.odometry_pose())
    assert math.dist(dead_reckoned[:2], truth[:2]) > 0.05  # odometry alone is off
    assert math.dist((sim.estimated_pose() or ())[:2], truth[:2]) < 0.3  # amcl is not


def test_a_map_goal_is_reached_by_the_estimate_not_by_the_truth() -> None:
    sim = engine()
    sim.set_initial_pose(*SPAWN)
    sim.localisation.map_to_odom = compose((0.2, 0.0, 0.0), sim.localisation.map_to_odom or ())
    goal = (SPAWN[0] - 1.0, SPAWN[1], SPAWN[2])
    true_goal = sim._true_goal(goal)
    assert close(true_goal, (goal[0] - 0.2, goal[1], goal[2]), 1e-9)


# ------------------------------------------------------------------ the lidar
def test_the_scan_sees_a_wall_and_a_person_at_their_distances() -> None:
    def clearance(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        return np.maximum(5.0 - xs, 0.0)  # a wall along x = 5

    spec = LidarSpec(samples=3, angle_min=-0.5, angle_max=0.5, noise_std=0.0)
    scanner = Scanner(clearance=clearance, spec=spec, person_radius=0.25)
    ranges = scanner.ranges((0.0, 0.0, 0.0), people=[])
    assert ranges[1] == pytest.approx(5.0 - 0.05, abs=0.03)  # the lidar is 5 cm ahead
    assert ranges[0] == pytest.approx(4.95 / math.cos(0.5), abs=0.05)
    ranges = scanner.ranges((0.0, 0.0, 0.0), people=[(2.0, 0.0)])
    assert ranges[1] == pytest.approx(2.0 - 0.25 - 0.05, abs=1e-4)
    behind = scanner.ranges((0.0, 0.0, math.pi), people=[])
    assert np.isinf(behind).all()  # facing away from the wall: nothing within 30 m


def test_the_office_scan_has_the_originals_beams_all_within_range() -> None:
    ranges = engine().scan_ranges()
    assert ranges.shape == (1875,) and ranges.dtype == np.float32
    finite = ranges[np.isfinite(ranges)]
    assert finite.size > 1800 and finite.min() >= 0.1 and finite.max() <= 30.0


# ------------------------------------------------------------------ over DDS
@pytest.fixture
def graph(ros_context: Context) -> Iterator[Graph]:
    yield Graph(ros_context, speed=0.0)


def test_odometry_tf_and_amcl_pose_over_ros_give_the_map_pose_after_initialpose(
        graph: Graph) -> None:
    odometry: list[Odometry] = []
    estimates: list[PoseWithCovarianceStamped] = []
    map_to_odom: list[TFMessage] = []
    scans: list[LaserScan] = []
    client = graph.client
    client.create_subscription(Odometry, "/servicebot/odom", odometry.append, 10)
    client.create_subscription(PoseWithCovarianceStamped, "/servicebot/amcl_pose",
                               estimates.append, LATCHED)
    client.create_subscription(TFMessage, "/tf", lambda m: map_to_odom.extend(
        t for t in m.transforms if t.header.frame_id == "map"), 100)
    client.create_subscription(LaserScan, "/servicebot/scan", scans.append,
                               qos_profile_sensor_data)
    graph.spin_until(lambda: bool(odometry) and bool(scans))
    first = odometry[0]
    assert (first.header.frame_id, first.child_frame_id) == ("odom", "base_footprint")
    assert (first.pose.pose.position.x, first.pose.pose.position.y) == (0.0, 0.0)
    assert first.pose.pose.orientation.w == 1.0
    assert not estimates and not map_to_odom  # not localised yet
    assert scans[0].header.frame_id == "lidar_frame" and len(scans[0].ranges) == 1875

    initial = PoseWithCovarianceStamped()
    initial.header.frame_id = "map"
    initial.pose.pose.position.x, initial.pose.pose.position.y = SPAWN[0], SPAWN[1]
    initial.pose.pose.orientation.z = math.sin(SPAWN[2] / 2.0)
    initial.pose.pose.orientation.w = math.cos(SPAWN[2] / 2.0)
    client.create_publisher(PoseWithCovarianceStamped, "/servicebot/initialpose",
                            LATCHED).publish(initial)
    graph.spin_until(lambda: bool(estimates) and bool(map_to_odom))
    assert estimates[0].header.frame_id == "map"
    assert estimates[0].pose.pose.position.x == pytest.approx(SPAWN[0])
    transform = map_to_odom[-1]
    assert transform.child_frame_id == "odom"
    assert transform.transform.translation.x == pytest.approx(SPAWN[0])
    assert transform.transform.translation.y == pytest.approx(SPAWN[1])
    assert 2.0 * math.atan2(transform.transform.rotation.z,
                            transform.transform.rotation.w) == pytest.approx(SPAWN[2])


# ------------------------------------------------------------------ the node's side
def initial_pose(pose: tuple[float, float, float], frame: str = "map") -> Any:
    message = PoseWithCovarianceStamped()
    message.header.frame_id = frame
    message.pose.pose.position.x, message.pose.pose.position.y = pose[0], pose[1]
    message.pose.pose.orientation.z = math.sin(pose[2] / 2.0)
    message.pose.pose.orientation.w = math.cos(pose[2] / 2.0)
    return message


@pytest.fixture
def simulator(ros_context: Context) -> Iterator[SimulatorNode]:
    settings = SimSettings(world=office(), seed=None, speed=0.0,
                           difficulty=Difficulty.default(), camera_rate_hz=0.0)
    node = Node("servicesim", context=ros_context)
    yield SimulatorNode(settings, node=node)
    node.destroy_node()


def test_an_initial_pose_outside_the_map_frame_is_ignored_as_amcl_ignores_it(
        simulator: SimulatorNode) -> None:
    simulator._on_initial_pose(initial_pose(SPAWN, frame="odom"))
    assert simulator.engine.estimated_pose() is None
    simulator._on_initial_pose(initial_pose(SPAWN))
    assert close(simulator.engine.estimated_pose() or (), SPAWN)


def test_navigation_feedback_gives_the_estimate_not_the_truth(simulator: SimulatorNode) -> None:
    guess = (SPAWN[0] + 0.5, SPAWN[1], SPAWN[2])  # off by half a metre: not converged yet
    simulator._on_initial_pose(initial_pose(guess))
    feedback = simulator._feedback(NavigationState(status="running"), started=0.0)
    position = feedback.current_pose.pose.position
    assert feedback.current_pose.header.frame_id == "map"
    assert (position.x, position.y) == pytest.approx(guess[:2])
