"""The simulated world, stepped at a fixed physics step in sim time, with no ROS in it.

:class:`SimEngine` owns the robot, the guest, the crowd, navigation and the referee, and applies
the competition's rules; the ROS node (:mod:`servicesim_sim.ros.node`) only turns its state into
messages and requests into calls. Keeping ROS out makes the rules testable in microseconds and
the engine deterministic: every random draw comes from generators seeded by the scenario.

One :meth:`SimEngine.step` is ``dt`` sim seconds: the robot drives (navigation's command, else
the last ``cmd_vel``, which persists as with ``gazebo_ros_diff_drive``: there is no timeout),
the guest follows, the crowd walks, the guest drifts at the scheduled world times or falls too
far behind, the referee checks the checkpoints that depend on where things are (1 and 4), and
contact and approximation penalties are booked from the start of the world
(:mod:`servicesim_sim.model.contacts`).

The referee's services and the checks of each step are the task's rules
(:mod:`servicesim_sim.model.task_rules`).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from servicesim_sim.model.camera import render_front_camera
from servicesim_sim.model.contacts import PERSON_BODY_RADIUS, PenaltyChecker
from servicesim_sim.model.guest import (
    Guest,
)
from servicesim_sim.model.localisation import (
    IDENTITY,
    AmclModel,
    Estimate,
    Pose,
    WheelOdometry,
    between,
    compose,
)
from servicesim_sim.model.people import Crowd, Person
from servicesim_sim.model.referee import Referee, RefereeReport
from servicesim_sim.model.robot import Robot, WallClearance
from servicesim_sim.model.scan import Scanner, surface_clearance
from servicesim_sim.model.scenario import Scenario
from servicesim_sim.model.task_rules import TaskRules
from servicesim_sim.navigation.navigator import Navigator
from servicesim_sim.navigation.parameters import SERVICEBOT, NavigationParameters
from servicesim_sim.world.files import OccupancyMap, PlacedWalker, WalkerRoute, World
from servicesim_sim.world.footprint import CIRCUMSCRIBED_RADIUS

PHYSICS_STEP_S = 0.02  # 50 Hz: the score topic's rate
RFID_RANGE_M = 2.0
RFID_WINDOW_M = RFID_RANGE_M + 1e-9  # a person farther along x or y is out of range, however
# the bounds round: only those within are measured
CONTROLLER_PERIOD_S = 0.05  # navigation's controller runs at 20 Hz, as Nav2's does by default
CROWD_PERIOD_STEPS = 2  # walkers move at 25 Hz: 5 cm a step at their fastest
TF_ERROR = 9002  # Nav2 NavigateToPose: no transform map -> base_link, i.e. not localised
NAV_ABORT_WINDOW_S = (1.0, 10.0)  # when a randomly aborted goal gives up


_WALL_CLEARANCES: weakref.WeakKeyDictionary[OccupancyMap, WallClearance] = (
    weakref.WeakKeyDictionary())


def wall_clearance(occupancy_map: OccupancyMap) -> WallClearance:
    """The map's :class:`WallClearance`, computed once per loaded map (a third of a second).

    Episodes a reset plays on one world (:mod:`servicesim_sim.ros.episodes` keeps its worlds)
    share it; its grid is made read-only, so an episode cannot change what the next one gets.
    """
    walls = _WALL_CLEARANCES.get(occupancy_map)
    if walls is None:
        walls = WallClearance(occupancy_map)
        walls.grid.setflags(write=False)
        _WALL_CLEARANCES[occupancy_map] = walls
    return walls


@dataclass(frozen=True)
class NavigationState:
    status: str  # "running", "succeeded", "aborted", "canceled"
    error_code: int = 0
    error_msg: str = ""
    distance_remaining: float = 0.0
    recoveries: int = 0


class SimEngine:
    """One world, one scenario; see the module docstring."""

    def __init__(self, *, world: World, scenario: Scenario, dt: float = PHYSICS_STEP_S,
                 navigation: NavigationParameters = SERVICEBOT) -> None:
        self.world, self.scenario, self.dt = world, scenario, dt
        self.sim_time = 0.0
        self.referee = Referee()
        walls = wall_clearance(world.map)
        task = scenario.task
        self.robot = Robot(x=task.start_x, y=task.start_y, yaw=task.start_yaw, walls=walls)
        self.guest = Guest(name=task.guest_name, x=task.guest_x, y=task.guest_y,
                           yaw=task.guest_yaw, wall_clearance=walls.at,
                           path=scenario.difficulty.guest_path)
        routes, placed = self._walker_routes()
        self.crowd = Crowd(world.map, rng=np.random.default_rng(scenario.people_seed),
                           walkers=world.people.walkers, idlers=world.people.idlers,
                           taken_names={task.guest_name}, keep_clear=self._keep_clear(),
                           occupied=[(task.guest_x, task.guest_y, PERSON_BODY_RADIUS),
                                     (task.start_x, task.start_y, CIRCUMSCRIBED_RADIUS)],
                           idling_areas=world.idling_areas,
                           walker_patience_s=world.people.walker_patience_s,
                           routes=routes, placed=placed)
        self.task_rules = TaskRules(referee=self.referee, guest=self.guest, robot=self.robot,
                                    world=world, task=task, drift_times=scenario.drift_times)
        self.penalty_checker = PenaltyChecker(robot=self.robot, guest=self.guest,
                                             crowd=self.crowd, referee=self.referee)
        self._knobs = np.random.default_rng(scenario.knob_seed)
        difficulty = scenario.difficulty
        self.odometry = WheelOdometry(drift=difficulty.odom_drift,
                                      rng=np.random.default_rng([scenario.knob_seed, 2]))
        self.localisation = AmclModel(noise=difficulty.localisation_noise,
                                      rng=np.random.default_rng([scenario.knob_seed, 3]))
        self._estimate_due = False
        self.scanner = Scanner(clearance=surface_clearance(
            walls.grid, origin=(world.map.origin_x, world.map.origin_y),
            resolution=world.map.resolution), person_radius=PERSON_BODY_RADIUS)
        self._scan_noise = np.random.default_rng([scenario.knob_seed, 4])
        self.navigator = Navigator(world.map, rng=np.random.default_rng(scenario.knob_seed + 1),
                                   parameters=navigation, body=self.robot.footprint)
        self._ticket = 0
        self._localised = False
        if world.amcl_initial_pose is not None:
            self.set_initial_pose(*world.amcl_initial_pose)  # AMCL's launch pose, as ROS 1's
        self._refused: dict[int, NavigationState] = {}
        self._cmd_vel = (0.0, 0.0)
        self._nav_driving = False
        self._next_control = 0.0
        self._seen_revision = -1
        self._steps = 0

    def _walker_routes(self) -> tuple[tuple[WalkerRoute, ...], tuple[PlacedWalker, ...]]:
        """The world's walker loops unless the knob asks for random ones (none: random), and
        the fixed task's own walkers on them (the shipped world file's) when no seed draws."""
        if self.scenario.difficulty.walker_routes == "random" or not self.world.walker_routes:
            return (), ()
        placed = self.world.walkers if self.scenario.seed is None else ()
        return self.world.walker_routes, placed

    def _keep_clear(self) -> list[tuple[float, float, float]]:
        """Where walker routes do not go (idlers may stand there, as in the original)."""
        task, areas = self.scenario.task, self.world.areas
        discs = [(task.start_x, task.start_y, 1.5), (task.guest_x, task.guest_y, 1.5)]
        for name in (task.pick_up, task.drop_off, task.start_area):
            x, y = areas[name].centre
            discs.append((x, y, 2.0))
        return discs

    # ------------------------------------------------------------------ the task
    @property
    def task_started(self) -> bool:
        return self.referee.started

    def task_running(self) -> bool:
        return self.referee.running

    def new_task(self) -> tuple[bool, str]:
        return self.task_rules.new_task(now=self.sim_time)

    def pickup(self, guest_name: str, robot_name: str) -> tuple[bool, str]:
        return self.task_rules.pickup(guest_name, robot_name)

    def dropoff(self, guest_name: str) -> tuple[bool, str]:
        return self.task_rules.dropoff(guest_name)

    def force_drift(self) -> tuple[bool, str]:
        return self.task_rules.force_drift()

    # ---------------------------------------------------------------- the robot
    def set_initial_pose(self, x: float, y: float, yaw: float) -> None:
        """Localisation input: the estimate starts at (x, y, yaw) in map (AMCL's initialpose)."""
        self._localised = True
        self.localisation.set_initial_pose((x, y, yaw), odom=self.odometry.pose,
                                           truth=self.robot.pose)
        self._estimate_due = True

    def command_velocity(self, v: float, w: float) -> None:
        """Drive with (v, w) until the next command, as ``gazebo_ros_diff_drive`` does (no
        timeout); a non-finite twist stops the robot.

        Clamping alone would not do: ``min(0.5, nan)`` is 0.5, full speed ahead.
        """
        if not (math.isfinite(v) and math.isfinite(w)):
            v = w = 0.0
        self._cmd_vel = (v, w)

    def robot_pose(self) -> tuple[float, float, float]:
        """The true pose in map: ground truth, for the referee, records and tests only."""
        return self.robot.pose

    def odometry_pose(self) -> Pose:
        """The wheel odometry: the pose in ``odom``, zero at the spawn pose."""
        return self.odometry.pose

    def estimated_pose(self) -> Pose | None:
        """The localisation's map pose now (map -> odom -> base); None, not localised."""
        return self.localisation.pose(self.odometry.pose)

    def new_estimate(self) -> Estimate | None:
        """The estimate AMCL would publish on ``amcl_pose`` since the last call, if any."""
        due, self._estimate_due = self._estimate_due, False
        return self.localisation.estimate if due else None

    def map_to_odom(self) -> tuple[float, float, float]:
        """The odom frame's pose (x, y, yaw) in map: the transform map -> odom.

        The one place that knows where odometry's origin lies; everything given in ``odom``
        (navigation goals) reaches ``map`` through it. It is the localisation's, as AMCL
        broadcasts it: from the start at the world's ``amcl_initial_pose`` (the office: the
        competitor's AMCL launch pose, as ROS 1 AMCL starts), else the identity until an initial
        pose (nothing is localised then, and navigation refuses every goal, as Nav2's does).
        """
        return self.localisation.map_to_odom or IDENTITY

    def robot_velocity(self) -> tuple[float, float]:
        return self.robot.v, self.robot.w

    def navigate(self, x: float, y: float, yaw: float) -> int:
        """Start a goal (preempting any other); the ticket names it in later calls."""
        self._ticket += 1
        if not self._localised:
            self._refused[self._ticket] = NavigationState(
                status="aborted", error_code=TF_ERROR,
                error_msg="robot not localised: publish /servicebot/initialpose first")
            return self._ticket
        x, y, yaw = self._true_goal((x, y, yaw))
        abort_after = None
        if self._knobs.random() < self.scenario.difficulty.nav_abort_probability:
            abort_after = float(self._knobs.uniform(*NAV_ABORT_WINDOW_S))
        self.navigator.start(x, y, yaw, now=self.sim_time, abort_after_s=abort_after)
        self._next_control = self.sim_time
        return self._ticket

    def _true_goal(self, goal: Pose) -> Pose:
        """Where the robot truly stands when its estimate reaches ``goal`` (in map).

        Nav2 drives its estimate to the goal; the robot follows the truth here, so the goal is
        moved by the estimate's error now (none when the estimate is the truth).
        """
        estimate = self.estimated_pose()
        if estimate is None:
            return goal
        return compose(self.robot.pose, between(estimate, goal))

    def cancel_navigation(self, ticket: int) -> None:
        if ticket == self._ticket:
            self.navigator.cancel()

    def navigation_state(self, ticket: int) -> NavigationState:
        if ticket in self._refused:
            return self._refused[ticket]
        if ticket != self._ticket:
            return NavigationState(status="canceled", error_msg="preempted by a newer goal")
        navigator = self.navigator
        return NavigationState(status=navigator.status, error_code=navigator.error_code,
                               error_msg=navigator.error_msg,
                               distance_remaining=navigator.distance_remaining,
                               recoveries=navigator.recoveries)

    def clear_costmaps(self) -> None:
        self.navigator.clear_costmaps()

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        dt = self.dt
        v, w = self._drive_command()
        self.robot.step(dt, v=v, w=w)
        self.odometry.update(v=self.robot.v, w=self.robot.w, dt=dt)
        if self.localisation.update(odom=self.odometry.pose, truth=self.robot.pose):
            self._estimate_due = True
        self.guest.record_robot(self.robot.x, self.robot.y)
        self.guest.step(dt, robot_x=self.robot.x, robot_y=self.robot.y)
        self._steps += 1
        if self._steps % CROWD_PERIOD_STEPS == 0:
            self.crowd.step(dt * CROWD_PERIOD_STEPS, robot=self.robot.pose,
                            others=[(self.guest.x, self.guest.y)])
        self.sim_time += dt
        self.referee.advance(dt)
        if self.referee.running:
            self.task_rules.check_areas()
        self.task_rules.check_guest(now=self.sim_time)
        self.penalty_checker.book(dt, now=self.sim_time)

    def _drive_command(self) -> tuple[float, float]:
        """Navigation's controller publishes on ``cmd_vel`` too: at 20 Hz while a goal runs, and
        a zero twist when it ends (as Nav2's controller server does). Otherwise the last
        command persists. Navigation's costmap sees the people at its own rate with or without
        a goal, as Nav2's and move_base's costmaps update whether or not they drive."""
        due = self.sim_time >= self._next_control - 1e-9
        if due:
            self._next_control = self.sim_time + CONTROLLER_PERIOD_S
        if self.navigator.status == "running":
            self._nav_driving = True
            if due:
                self._cmd_vel = self.navigator.command(
                    pose=self.robot.pose, people=self._obstacles(), now=self.sim_time)
            return self._cmd_vel
        if self._nav_driving:
            self._nav_driving = False
            self._cmd_vel = (0.0, 0.0)
        if due and self.navigator.observation_due(self.sim_time):
            self.navigator.observe(pose=self.robot.pose, people=self._obstacles(),
                                   now=self.sim_time)
        return self._cmd_vel

    def _obstacles(self) -> list[tuple[float, float]]:
        """Everyone, the guest included, following or not: the costmap marks those the lidar
        sees (±120°), as Nav2's would. A guest walking behind the robot is out of its view; a
        robot that turns back towards them sees them and does not drive into them."""
        return [(person.x, person.y) for person in self.crowd.people] + [
            (self.guest.x, self.guest.y)]

    # ------------------------------------------------------------------ sensors
    def rfid_names(self) -> list[str] | None:
        """Everyone within 2 m, in the world's order (walkers, idlers, then the guest, as the
        original's world file lists its actors and ``VicinityPlugin.cc`` reports them); None
        (nothing published) when nobody is, or a reading is lost."""
        x, y = self.robot.x, self.robot.y
        low_x, high_x = x - RFID_WINDOW_M, x + RFID_WINDOW_M
        low_y, high_y = y - RFID_WINDOW_M, y + RFID_WINDOW_M
        everyone: list[Person | Guest] = [*self.crowd.people, self.guest]
        names = [person.name for person in everyone
                 if low_x < person.x < high_x and low_y < person.y < high_y
                 and math.hypot(person.x - x, person.y - y) <= RFID_RANGE_M]
        if not names or self._knobs.random() < self.scenario.difficulty.rfid_dropout:
            return None
        return names

    def people_states(self) -> list[tuple[str, str, float, float]]:
        return [*self.crowd.states(), (self.guest.name, "guest", self.guest.x, self.guest.y)]

    def guest_state(self) -> str:
        return self.guest.state.value

    def scan_ranges(self) -> np.ndarray:
        """One lidar sweep from the true pose (:mod:`servicesim_sim.model.scan`)."""
        people = [(x, y) for _, _, x, y in self.people_states()]
        return self.scanner.ranges(self.robot.pose, people, rng=self._scan_noise)

    def camera_image(self) -> np.ndarray:
        return render_front_camera(robot=self.robot.pose, people=self.people_states(),
                                   guest_name=self.guest.name, occupancy_map=self.world.map)

    # ------------------------------------------------------------------ referee
    def score(self) -> float:
        return self.referee.score()

    def referee_report(self) -> RefereeReport:
        return self.referee.report()

    def penalty_causes(self) -> tuple[int, dict[str, float]]:
        """How many steps booked contact or approximation points so far, and the points by
        cause (the referee's running sums, see :mod:`servicesim_sim.model.referee`)."""
        penalties = self.referee.penalties
        return penalties.bookings, penalties.by_cause

    def referee_changed(self) -> bool:
        """Whether a referee event happened since the last call."""
        changed = self.referee.revision != self._seen_revision
        self._seen_revision = self.referee.revision
        return changed
