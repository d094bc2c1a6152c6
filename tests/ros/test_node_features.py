"""What the plumbing asks of a node by type: the executive's node has every feature, a plain
rclpy node none, and asking a plain node for one changes nothing."""

from __future__ import annotations

from typing import Any

import pytest
from rclpy.node import Node

from bt_servicesim.ros.lockstep import LockstepClient, LockstepHost, lockstep_of
from bt_servicesim.ros.node import ExecutiveNode
from bt_servicesim.ros.node_features import ErrorKeeper, keep_error


def test_the_executive_node_keeps_errors_and_hosts_lockstep(ros_context: Any) -> None:
    node = ExecutiveNode("executive_under_test", context=ros_context)
    try:
        assert isinstance(node, ErrorKeeper) and isinstance(node, LockstepHost)
        assert lockstep_of(node) is None  # not joined
        assert keep_error(node, ValueError("first"), where="a tick")
        assert keep_error(node, ValueError("second"), where="a tick")
        assert node.callback_error == "ValueError in a tick: first"
        client = LockstepClient(node, name="under_test")
        node.lockstep = client  # as the join leaves it
        assert lockstep_of(node) is client
    finally:
        node.destroy_node()


def test_a_plain_node_has_none_of_them(ros_context: Any) -> None:
    node = Node("plain_under_test", context=ros_context)
    try:
        assert not isinstance(node, ErrorKeeper) and not isinstance(node, LockstepHost)
        assert not keep_error(node, ValueError("lost"), where="a tick")
        assert lockstep_of(node) is None
        with pytest.raises(TypeError, match="counts its traffic"):
            LockstepClient(node, name="under_test")
    finally:
        node.destroy_node()
