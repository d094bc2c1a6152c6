"""Lockstep, the simulator's side: the gate's rule, the protocol's messages and the server.

Design intent: a seed replays only if the world's history does not depend on how fast the
processes run, so a joined client holds the simulator to its ticks. The rule
(:mod:`~servicesim_sim.lockstep.gate`) is free of ROS and tested directly; the server
(:mod:`~servicesim_sim.lockstep.server`) wires it to the node, with the join service
(:mod:`~servicesim_sim.lockstep.joining`) and the clients' done messages
(:mod:`~servicesim_sim.lockstep.dones`). The protocol is described in
``docs/reference/simulator.md#lockstep``.
"""
