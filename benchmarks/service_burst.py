"""Bursts of service requests against the real simulator: how many are answered, and how fast.

``python benchmarks/service_burst.py [--bursts 1000,10000] [--rounds 3] [--speed 0]`` starts
``python -m servicesim_sim`` and, from a client node in this process, sends each burst of
``/servicesim/room_info`` requests at once and waits (up to ``--wait`` wall seconds) until every
one is answered. Each burst comes from a client created just before it, which sends as soon as it
sees the service: the simulator may take the first requests before its reply writer has matched
the new client's reply reader (discovery is not symmetric), and must answer those too.

Printed per burst: requests answered of those sent, wall seconds from the first request sent to
the last answer, and answers per second. The client keeps as many replies as it sends (a reply
reader keeps only its depth). Figures are wall-clock on this machine and vary with its load;
nothing here is asserted, but the exit status is 1 when a burst was not answered in full. Bad
arguments give one line and exit status 2.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from typing import Any

from ros_harness import Simulator, isolate, spin_until, start_task

from bt_servicesim.cli import OneLineArgumentParser

ROOM = "FrontElevator"


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/service_burst.py",
                                   description="Bursts of room_info requests, all answered?")
    parser.add_argument("--bursts", default="1000,10000",
                        help="comma list of burst sizes (default 1000,10000)")
    parser.add_argument("--rounds", type=int, default=3, help="bursts of each size (default 3)")
    parser.add_argument("--speed", type=float, default=0.0,
                        help="the simulator's speed factor (default 0: as fast as it can)")
    parser.add_argument("--wait", type=float, default=300.0,
                        help="wall seconds to wait for one burst's answers (default 300)")
    return parser


def bursts_from(text: str) -> list[int]:
    try:
        sizes = [int(part) for part in text.split(",")]
    except ValueError:
        build_parser().error(f"--bursts {text}: not a comma list of whole numbers")
    if any(size < 1 for size in sizes):
        build_parser().error(f"--bursts {text}: every burst must be 1 request or more")
    return sizes


def burst(node: Any, executor: Any, simulator: Simulator, size: int,
          wait_s: float) -> tuple[int, float]:
    """Send ``size`` requests from a new client at once; how many were answered, in how long."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from servicesim_competition.srv import RoomInfo

    every_reply = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=size,
                             reliability=ReliabilityPolicy.RELIABLE)
    client = node.create_client(RoomInfo, "/servicesim/room_info", qos_profile=every_reply)
    try:
        spin_until(executor, client.service_is_ready, 60.0, "room_info", simulator)
        answers: list[float] = []  # when each came; counted as they come, not by a scan

        def note(_: Any) -> None:
            answers.append(time.perf_counter())

        began = time.perf_counter()
        for _ in range(size):
            client.call_async(RoomInfo.Request(name=ROOM)).add_done_callback(note)
        deadline = time.monotonic() + wait_s
        while len(answers) < size and time.monotonic() < deadline:
            simulator.check_running()
            executor.spin_once(timeout_sec=0.05)
        answered = len(answers)
        elapsed = (answers[-1] if answers else time.perf_counter()) - began
    finally:
        node.destroy_client(client)
    return answered, elapsed


def measure(sizes: Sequence[int], rounds: int, speed: float, wait_s: float) -> bool:
    """Print every burst's figures; whether every burst was answered in full."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    simulator = Simulator(speed=speed)
    node = Node(f"benchmark_service_burst_{os.getpid()}")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    whole = True
    try:
        start_task(node, executor, simulator)
        print(f"simulator at speed {speed:g}; room_info bursts, each from a new client:")
        for size in sizes:
            for _ in range(rounds):
                answered, elapsed = burst(node, executor, simulator, size, wait_s)
                whole &= answered == size
                print(f"  burst {size:6d}: {answered:6d} answered in {elapsed:7.2f} s  "
                      f"({answered / elapsed:7.0f} answers/s)", flush=True)
    finally:
        executor.shutdown()
        node.destroy_node()
        simulator.stop()
    return whole


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    sizes = bursts_from(args.bursts)
    if args.rounds < 1:
        build_parser().error(f"--rounds {args.rounds}: must be 1 or more")
    if not args.speed >= 0.0:
        build_parser().error(f"--speed {args.speed}: must be 0 or more")
    if not args.wait > 0.0:
        build_parser().error(f"--wait {args.wait}: must be more than 0")
    domain = isolate()
    import rclpy

    print(f"ROS domain {domain}, discovery {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}, "
          f"{os.cpu_count()} CPUs")
    rclpy.init()
    try:
        whole = measure(sizes, args.rounds, args.speed, args.wait)
    finally:
        rclpy.try_shutdown()
    return 0 if whole else 1


if __name__ == "__main__":
    sys.exit(main())
