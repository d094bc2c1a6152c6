"""The executive's node stays clear of the ``EventsExecutor``'s two known crashes.

A callback that raises segfaults the Kilted wheels' ``EventsExecutor`` (ros2/rclpy#1641), and so
does destroying publishers or subscriptions with QoS-event callbacks while discovery churns
(ros2/rclpy#1644). Each case runs in a child process, so that a crash fails the test instead of
taking the test run down.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

RAISING_CALLBACK = textwrap.dedent("""
    import time
    import rclpy
    from rclpy.experimental import EventsExecutor
    from std_msgs.msg import String
    from bt_servicesim.ros.node import ExecutiveNode

    rclpy.init()
    node = ExecutiveNode("raising", use_sim_time=False)
    calls = []

    def callback(message):
        calls.append(message.data)
        raise ValueError("broken reader")

    node.create_subscription(String, "/raising", callback, 10)
    publisher = node.create_publisher(String, "/raising", 10)
    executor = EventsExecutor()
    executor.add_node(node)
    deadline = time.monotonic() + 20
    while len(calls) < 3 and time.monotonic() < deadline:
        publisher.publish(String(data="x"))
        executor.spin_once(timeout_sec=0.05)
    print(len(calls), node.callback_error)
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown()
""")

DISCOVERY_STORM = textwrap.dedent("""
    import multiprocessing, time
    import rclpy
    from rclpy.experimental import EventsExecutor
    from std_msgs.msg import String
    from bt_servicesim.ros.node import ExecutiveNode

    def storm():
        rclpy.init()
        node = rclpy.create_node("storm")
        while True:
            subs = [node.create_subscription(String, f"/churn_{i % 10}", lambda m: None, 10)
                    for i in range(20)]
            time.sleep(0.01)
            for sub in subs:
                node.destroy_subscription(sub)

    if __name__ == "__main__":
        other = multiprocessing.Process(target=storm, daemon=True)
        other.start()
        rclpy.init()
        node = ExecutiveNode("listener", use_sim_time=False)
        executor = EventsExecutor()
        executor.add_node(node)
        for round_ in range(30):  # the reproducer's pattern: endpoints made and destroyed
            publishers = [node.create_publisher(String, f"/churn_{j}", 10) for j in range(10)]
            time.sleep(0.01)
            executor.spin_once(timeout_sec=0)
            for publisher in publishers:
                node.destroy_publisher(publisher)
        other.terminate()
        print("survived")
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown()
""")


def run_script(script: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120)


def test_a_raising_callback_is_kept_and_the_process_goes_on() -> None:
    result = run_script(RAISING_CALLBACK)
    assert result.returncode == 0, result.stderr[-2000:]
    count, error = result.stdout.split(" ", 1)
    assert int(count) >= 3  # it kept spinning after the first exception
    assert error.strip().startswith("ValueError in ") and "broken reader" in error


def test_discovery_churn_beside_the_executive_node_does_not_crash_it() -> None:
    result = run_script(DISCOVERY_STORM)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip() == "survived"
