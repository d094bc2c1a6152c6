"""The model stepped in sim time: the robot, the guest, the people, the sensors and the referee.

Design intent: :class:`~servicesim_sim.model.engine.SimEngine` owns everything that happens
and applies the competition's rules at a fixed physics step, every random draw from
generators the scenario seeds, so that a seed replays exactly and the rules are tested in
microseconds. No ROS here (an import contract checks it): the ROS face
(:mod:`servicesim_sim.ros`) only turns the model's state into messages.
"""
