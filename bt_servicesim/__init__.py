"""A py_trees behaviour-tree mission executive for ROS 2, playing OSRF's ServiceSim task.

The top-level modules are the commands (``run``, ``evaluate``, ``dump``, ``replay``,
``trajectory``, ``tree_model``) over ``cli``; the packages are the library, each one concept:
``behaviours`` (the tree's nodes), ``ros`` (plumbing), ``planning`` (ROS-free algorithms),
``tree`` (loading and ticking a tree), ``mission`` (one run on a live graph), ``records`` (what a
run leaves behind) and ``evaluation`` (many runs compared). docs/architecture.md draws it.
"""
