"""Navigation as Nav2 would do it: the costmap, the global planner, the path follower, goals,
and the lower bound on path lengths.

Design intent: plain NumPy and SciPy over the world's occupancy map, stepped by the model in
sim time and tested directly; no ROS (an import contract checks it). The NavigateToPose
action on ROS is :mod:`servicesim_sim.ros`'s.
"""
