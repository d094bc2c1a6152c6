"""Spinning from a test's thread: a bounded :func:`spin_until`, :func:`wait_for_subscription`,
the ``/clock`` message of a sim time (:func:`clock_message`), and node names DDS has not seen
(:func:`unique_name`)."""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Time
from rclpy.executors import Executor
from rclpy.publisher import Publisher
from rosgraph_msgs.msg import Clock

_names = itertools.count()


def unique_name(prefix: str) -> str:
    """``prefix`` with a number no other name of this process has: DDS remembers old nodes."""
    return f"{prefix}_{next(_names)}"



def spin_until(executor: Executor, done: Callable[[], bool], what: str = "the condition", *,
               before: Callable[[], Any] = lambda: None, limit_s: float = 20.0,
               step_s: float = 0.01) -> None:
    """Spin ``executor`` until ``done()``, calling ``before()`` ahead of each spin; fail after
    ``limit_s`` wall seconds."""
    deadline = time.monotonic() + limit_s
    while not done():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        before()
        executor.spin_once(timeout_sec=step_s)


def wait_for_subscription(publisher: Publisher, limit_s: float = 10.0) -> None:
    """Wait (without spinning) until a subscription has matched ``publisher``."""
    deadline = time.monotonic() + limit_s
    while publisher.get_subscription_count() == 0:
        assert time.monotonic() < deadline, f"nobody subscribed to {publisher.topic_name}"
        time.sleep(0.01)


def clock_message(seconds: float, *, nanoseconds_short: int = 0) -> Clock:
    """The ``/clock`` message for ``seconds`` of sim time (less ``nanoseconds_short``)."""
    total = round(seconds * 1e9) - nanoseconds_short
    return Clock(clock=Time(sec=total // 10**9, nanosec=total % 10**9))
