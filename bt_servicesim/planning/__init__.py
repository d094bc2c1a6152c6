"""Algorithms of the mission, free of ROS and py_trees: geometry, the occupancy grid, goals,
exploration and guest localisation, and the competition's rules they all read.

Everything here is plain Python and NumPy, tested directly; behaviours are thin wrappers over
it. An import contract checks that nothing here imports rclpy, py_trees or a message package.
"""
