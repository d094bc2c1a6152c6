"""The simulator's ROS 2 face: the node, its topics, services and navigation action, resets.

Design intent: a thin face over the model: everything that happens lives in
:class:`~servicesim_sim.model.engine.SimEngine`; the node steps it, turns its state into
messages and requests into engine calls.
"""
