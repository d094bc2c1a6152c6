"""ROS plumbing for the executive: the node, shared subscriptions and clients, the sim clock.

No tree logic lives here (an import contract checks that nothing here imports py_trees); the
behaviours and the run build on it.
"""
