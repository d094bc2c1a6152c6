"""One mission on a live ROS graph: the simulator process, the run, its progress and report."""
