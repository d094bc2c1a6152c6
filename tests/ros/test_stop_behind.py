"""A stop signal that lands inside rclpy's C++ reaches Python as pybind11's TypeError with the
stop as its cause (seen in CI: SIGINT while a feedback message was converted). The run must
treat it as the stop it is: exit 130 and "interrupted", not "the run failed: TypeError"."""

from __future__ import annotations

import pytest

from bt_servicesim.ros.node import stop_behind


def converted(stop: BaseException) -> TypeError:
    """What pybind11 raises when a conversion's Python code was interrupted by ``stop``."""
    try:
        try:
            raise stop
        except BaseException as cause:
            raise TypeError("Unable to convert function return value to a Python type!") \
                from cause
    except TypeError as error:
        return error


def test_a_stop_behind_a_conversion_error_is_found() -> None:
    stop = KeyboardInterrupt()
    assert stop_behind(converted(stop)) is stop


def test_an_error_with_no_stop_behind_it_is_an_error() -> None:
    assert stop_behind(converted(ValueError("a bug"))) is None
    assert stop_behind(RuntimeError("plain")) is None


def test_a_guarded_callback_lets_the_stop_through_and_keeps_no_error(
        ros_context: object) -> None:
    from bt_servicesim.ros.node import ExecutiveNode

    node = ExecutiveNode("stop_behind_test", context=ros_context)
    try:
        def interrupted() -> None:
            raise converted(KeyboardInterrupt())

        with pytest.raises(KeyboardInterrupt):
            node.guarded(interrupted)()
        assert node.callback_error is None
    finally:
        node.destroy_node()
