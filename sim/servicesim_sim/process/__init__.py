"""The simulator's process around rclpy: its executor, its pace, its stop signals, its DDS.

Design intent: the loop owns time, so the machinery it runs on is the simulator's own: an
executor that drains what is ready and never spins on a parked task, pacing sim time against
the wall clock, the stop signals taken over first thing, and discovery kept on loopback. None
of it knows the competition's topics, services or rules.
"""
