"""Watching a live tree from outside the process: a Groot2 monitor server (BehaviorTree.CPP v4)."""
