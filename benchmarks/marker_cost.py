"""What the scene's markers cost to publish: CDR bytes from templates against rclpy messages.

``python benchmarks/marker_cost.py [--seed S] [--sim-seconds T] [--rounds R]`` steps a seeded
engine on the shipped office for ``T`` sim seconds (default 90), the robot sent to its pick-up
area, and keeps the scene's update every 0.5 sim s as the simulator draws it
(:class:`~servicesim_sim.model.markers.SceneTracker`). It then publishes those updates on a topic
this process also subscribes to, ``R`` rounds (default 10), each round both ways in turn:

* as the simulator does, the bytes written from each marker's template
  (:mod:`servicesim_sim.wire.marker_messages`);
* as rclpy messages (``tests/sim/marker_reference.py``, the reference the bytes are tested
  against), which ``Publisher.publish`` converts and serialises.

It prints, for each way, the process's CPU time (user + system) per sim second of updates,
median and range over the rounds; the stepping is not counted. Nothing here is asserted.
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from ros_harness import REPO, isolate

from bt_servicesim.cli import OneLineArgumentParser

sys.path.insert(0, str(REPO))  # tests.sim.marker_reference, the rclpy messages
UPDATE_STEPS = 25  # physics steps (50 Hz) between two scenes: 0.5 sim s


def scene_updates(seed: int, sim_seconds: float) -> list[Any]:
    """A seeded engine's scene every 0.5 sim s, the robot driving to the pick-up area."""
    from servicesim_sim.model.engine import SimEngine
    from servicesim_sim.model.markers import SceneTracker
    from servicesim_sim.model.scenario import make_scenario
    from servicesim_sim.world.files import DEFAULT_WORLD, load_world

    world = load_world(DEFAULT_WORLD)
    engine = SimEngine(world=world, scenario=make_scenario(world, seed=seed))
    engine.navigate(*world.areas[engine.scenario.task.pick_up].centre, 0.0)
    tracker, updates = SceneTracker(), []
    for _ in range(round(sim_seconds * 2)):
        for _ in range(UPDATE_STEPS):
            engine.step()
        navigator = engine.navigator
        updates.append(tracker.update(
            engine.people_states(), navigator.path if navigator.status == "running" else []))
    return updates


def publishers(updates: list[Any]) -> dict[str, Callable[[], None]]:
    """Each way of publishing every update once, on a topic with a subscriber."""
    import rclpy
    from builtin_interfaces.msg import Time
    from visualization_msgs.msg import MarkerArray

    from servicesim_sim.wire.marker_messages import MarkerArrayBytes
    from tests.sim.marker_reference import marker_array

    rclpy.init()
    node = rclpy.create_node("marker_cost")
    publisher = node.create_publisher(MarkerArray, "/marker_cost", 10)
    node.create_subscription(MarkerArray, "/marker_cost", lambda _: None, 10, raw=True)
    stamps = [divmod(number * 500_000_000, 1_000_000_000) for number in range(len(updates))]

    def templates() -> None:
        encoder = MarkerArrayBytes()
        for update, stamp in zip(updates, stamps, strict=True):
            publisher.publish(encoder.encode(update, stamp=stamp))

    def messages() -> None:
        for update, (sec, nanosec) in zip(updates, stamps, strict=True):
            publisher.publish(marker_array(update, now=Time(sec=sec, nanosec=nanosec)))

    return {"CDR bytes from templates": templates, "rclpy messages": messages}


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog="python benchmarks/marker_cost.py",
                                   description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=5, help="the task's seed (default 5)")
    parser.add_argument("--sim-seconds", type=float, default=90.0,
                        help="sim seconds of scenes (default 90)")
    parser.add_argument("--rounds", type=int, default=10, help="rounds of each way (default 10)")
    args = parser.parse_args(argv)
    if args.sim_seconds < 0.5:
        parser.error(f"--sim-seconds {args.sim_seconds:g}: must be at least 0.5")
    if args.rounds < 1:
        parser.error(f"--rounds {args.rounds}: must be at least 1")
    print(f"ROS domain {isolate()}")
    updates = scene_updates(args.seed, args.sim_seconds)
    markers = sum(len(u.clear) + len(u.delete) + len(u.add) for u in updates)
    print(f"seed {args.seed}: {len(updates)} updates, {markers} markers, "
          f"{args.sim_seconds:g} sim s")
    ways = publishers(updates)
    spent: dict[str, list[float]] = {name: [] for name in ways}
    for _ in range(args.rounds):
        for name, publish_all in ways.items():
            start = time.process_time()
            publish_all()
            spent[name].append(1000.0 * (time.process_time() - start) / args.sim_seconds)
    for name, figures in spent.items():
        print(f"{name}: {statistics.median(figures):.3f} ms CPU per sim s "
              f"(range {min(figures):.3f}-{max(figures):.3f}, {args.rounds} rounds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
