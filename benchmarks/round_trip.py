"""Service and action round-trip times against the real simulator, median and p99.

``python benchmarks/round_trip.py [--calls N] [--speeds 10,0]`` starts ``python -m
servicesim_sim`` once per speed factor and, from a client node in this process, times

* services: ``/servicesim/room_info`` (a lookup) and ``/servicebot/move_base/clear_costmaps``,
  request sent to answer received;
* the NavigateToPose action: goal sent to goal accepted, cancel sent to cancel accepted (for a
  goal across the building), and goal sent to result received for a goal at the robot's own
  pose, which the simulator's navigation declares reached at its next check, 0.1 s of sim time
  later, so this one also measures how fast sim time passes.

The task is started first (before ``new_task`` the simulator never runs faster than real time).
The simulator answers between its physics steps, so times depend on the speed factor: with a
factor it waits for the wall clock while spinning (answers come at once), at 0 it never waits.
Figures are wall-clock on this machine and vary with its load; nothing here is asserted. Bad
arguments give one line and exit status 2.
"""

from __future__ import annotations

import itertools
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

from ros_harness import (
    Simulator,
    isolate,
    milliseconds,
    spin_until,
    start_task,
)

from bt_servicesim.cli import OneLineArgumentParser
from bt_servicesim.ros.messages import pose_to_msg

if TYPE_CHECKING:  # rclpy is imported once the domain is set
    from rclpy.client import Client as ServiceClient
    from servicesim_competition.srv import RoomInfo
    from std_srvs.srv import Empty

    from bt_servicesim.ros.navigate_to_pose import NavigationClient

_NUMBERS = itertools.count()
FAR_GOAL = (-20.1, 10.0)  # across the building from the shipped start
START = (10.975, 3.75, math.pi)  # the shipped task's start pose


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/round_trip.py",
                                   description="Service and action round trips.")
    parser.add_argument("--calls", type=int, default=200, help="round trips per kind")
    parser.add_argument("--speeds", default="10,0",
                        help="comma list of simulator speed factors (default 10,0)")
    return parser


def speeds_from(text: str) -> list[float]:
    try:
        speeds = [float(part) for part in text.split(",")]
    except ValueError:
        build_parser().error(f"--speeds {text}: not a comma list of numbers")
    if any(not speed >= 0.0 for speed in speeds):
        build_parser().error(f"--speeds {text}: every speed must be 0 or more")
    return speeds


class Client:
    """The timing client: a node, its executor and the handles it times."""

    def __init__(self, simulator: Simulator) -> None:
        from nav2_msgs.action import NavigateToPose
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from servicesim_competition.srv import RoomInfo
        from std_srvs.srv import Empty

        self.simulator = simulator
        self.node = Node(f"benchmark_round_trip_{os.getpid()}_{next(_NUMBERS)}")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.room_info: ServiceClient[RoomInfo.Request, RoomInfo.Response] = (
            self.node.create_client(RoomInfo, "/servicesim/room_info"))
        self.clear: ServiceClient[Empty.Request, Empty.Response] = self.node.create_client(
            Empty, "/servicebot/move_base/clear_costmaps")
        self.navigate: NavigationClient = ActionClient(self.node, NavigateToPose,
                                                       "/servicebot/navigate_to_pose")
        self.goal_type = NavigateToPose.Goal

    def wait_until_ready(self) -> None:
        spin_until(self.executor, lambda: self.room_info.service_is_ready()
                   and self.clear.service_is_ready() and self.navigate.server_is_ready(),
                   60.0, "the simulator's services", self.simulator)

    def complete(self, future: Any, what: str) -> Any:
        spin_until(self.executor, future.done, 30.0, what, self.simulator)
        return future.result()

    def timed(self, start: Callable[[], Any], what: str) -> tuple[float, Any]:
        began = time.perf_counter()
        result = self.complete(start(), what)
        return time.perf_counter() - began, result

    def goal(self, x: float, y: float, yaw: float) -> Any:
        from bt_servicesim.planning.geometry import Pose2D

        message = self.goal_type()
        message.pose.header.frame_id = "map"
        message.pose.pose = pose_to_msg(Pose2D(x, y, yaw))
        return message

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


def localise(client: Client) -> None:
    """Publish the start pose (the simulator, like AMCL, accepts goals only once localised)."""
    from geometry_msgs.msg import PoseWithCovarianceStamped

    from bt_servicesim.planning.geometry import Pose2D
    from bt_servicesim.ros.initial_pose import INITIAL_POSE_QOS, initial_pose_message

    publisher = client.node.create_publisher(PoseWithCovarianceStamped,
                                             "/servicebot/initialpose", INITIAL_POSE_QOS)
    publisher.publish(initial_pose_message(Pose2D(*START)))
    settle = time.monotonic() + 1.0
    spin_until(client.executor, lambda: time.monotonic() > settle, 5.0, "")


def services(client: Client, calls: int) -> None:
    from servicesim_competition.srv import RoomInfo
    from std_srvs.srv import Empty

    lookups = [client.timed(lambda: client.room_info.call_async(
        RoomInfo.Request(name="FrontElevator")), "room_info")[0] for _ in range(calls)]
    clears = [client.timed(lambda: client.clear.call_async(Empty.Request()),
                           "clear_costmaps")[0] for _ in range(calls)]
    print(f"  service room_info        {milliseconds(lookups)}")
    print(f"  service clear_costmaps   {milliseconds(clears)}")


def actions(client: Client, calls: int) -> None:
    from action_msgs.msg import GoalStatus

    accepts, cancels, results, reached = [], [], [], 0
    for _ in range(calls):
        far = client.goal(*FAR_GOAL, 0.0)
        seconds, handle = client.timed(partial(client.navigate.send_goal_async, far),
                                       "goal acceptance")
        accepts.append(seconds)
        cancels.append(client.timed(handle.cancel_goal_async, "cancel")[0])
        client.complete(handle.get_result_async(), "the cancelled goal's result")
    for _ in range(calls):
        here = client.goal(*START)
        began = time.perf_counter()
        handle = client.complete(client.navigate.send_goal_async(here), "goal acceptance")
        wrapped = client.complete(handle.get_result_async(), "the goal's result")
        results.append(time.perf_counter() - began)
        reached += wrapped.status == GoalStatus.STATUS_SUCCEEDED
    print(f"  action goal accepted     {milliseconds(accepts)}")
    print(f"  action cancel accepted   {milliseconds(cancels)}")
    print(f"  action goal to result    {milliseconds(results)}  ({reached} reached)")


def measure(speed: float, calls: int) -> None:
    simulator = Simulator(speed=speed)
    client = Client(simulator)
    try:
        client.wait_until_ready()
        start_task(client.node, client.executor, simulator)
        localise(client)
        print(f"simulator at speed {speed:g}:")
        services(client, calls)
        actions(client, calls)
    finally:
        client.close()
        simulator.stop()


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.calls < 1:
        build_parser().error(f"--calls {args.calls}: must be 1 or more")
    speeds = speeds_from(args.speeds)
    domain = isolate()
    import rclpy

    print(f"ROS domain {domain}, discovery {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}, "
          f"{os.cpu_count()} CPUs")
    rclpy.init()
    try:
        for speed in speeds:
            measure(speed, args.calls)
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
