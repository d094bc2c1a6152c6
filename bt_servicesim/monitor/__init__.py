"""Watching a run from outside while it goes on: servers that viewers connect to.

``foxglove_bridge`` serves the run's ROS topics to Foxglove (``run --foxglove``).
"""
