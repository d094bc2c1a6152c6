"""Watching a run from outside the process while it goes on: servers that viewers connect to.

The Groot2 monitor server (BehaviorTree.CPP v4's protocol: ``groot2_protocol``, ``groot2_tree``,
``groot2_server``; ``run --groot``) serves the live tree; Foxglove's WebSocket server
(``live_server``) and the bridge that forwards the recorded topics to it (``foxglove_bridge``;
``run --foxglove``) serve the live ROS topics.
"""
