"""What the front camera costs the simulator: CPU per sim second with one subscriber.

``python benchmarks/camera_cost.py [--rates 0,2,10,24] [--sim-seconds 20]`` starts the
simulator on the shipped world at real time (before a task it never runs faster) once per
camera rate, subscribes to the camera, and prints for each rate the simulator's CPU (user +
system) per sim second and the images received per sim second. The difference to rate 0 is
the camera's share; a process needing more than 1000/X ms per sim second cannot run X times
faster than real time.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

from ros_harness import Simulator, isolate, spin_until

from bt_servicesim.cli import OneLineArgumentParser

WARM_UP_SIM_S = 3.0


def process_cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far (Linux /proc)."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(rate: float, sim_seconds: float) -> tuple[float, float]:
    """(ms CPU per sim s, images per sim s) of a simulator at camera ``rate``."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Image

    simulator = Simulator(speed=1.0, arguments=["--camera-rate", repr(rate)])
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node("camera_cost", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        clock, images = [0.0], [0]
        node.create_subscription(
            Clock, "/clock", lambda m: clock.__setitem__(0, m.clock.sec + m.clock.nanosec / 1e9),
            10)
        node.create_subscription(Image, "/servicebot/camera_front/image_raw",
                                 lambda _: images.__setitem__(0, images[0] + 1), 50)
        spin_until(executor, lambda: clock[0] >= WARM_UP_SIM_S, 60.0, "the clock", simulator)
        cpu0, sim0, images0 = process_cpu_s(simulator.process.pid), clock[0], images[0]
        spin_until(executor, lambda: clock[0] >= sim0 + sim_seconds, 10.0 * sim_seconds,
                   "the measured sim seconds", simulator)
        cpu1, sim1, images1 = process_cpu_s(simulator.process.pid), clock[0], images[0]
    finally:
        simulator.stop()
        rclpy.shutdown(context=context)
    span = sim1 - sim0
    return 1000.0 * (cpu1 - cpu0) / span, (images1 - images0) / span


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog="python benchmarks/camera_cost.py",
                                   description=__doc__.splitlines()[0])
    parser.add_argument("--rates", default="0,2,10,24",
                        help="camera rates to measure, comma-separated (default 0,2,10,24)")
    parser.add_argument("--sim-seconds", type=float, default=20.0,
                        help="sim seconds measured per rate (default 20)")
    args = parser.parse_args(argv)
    try:
        rates = [float(rate) for rate in args.rates.split(",")]
    except ValueError:
        parser.error(f"--rates {args.rates!r}: must be numbers separated by commas")
    if args.sim_seconds <= 0.0:
        parser.error(f"--sim-seconds {args.sim_seconds:g}: must be more than 0")
    print(f"ROS domain {isolate()}")
    for rate in rates:
        cpu, images = measure(rate, args.sim_seconds)
        print(f"camera rate {rate:g}: {cpu:.0f} ms CPU per sim s, {images:.1f} images per sim s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
