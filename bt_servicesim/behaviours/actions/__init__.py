"""The mission tree's actions: leaves that do something or wait for something.

One node per file where a node is substantial; small nodes that share a base class and a
concept share a file (``task``: NewTask and TaskInfo; ``guest_services``: PickUpGuest and
DropOffGuest; ``goals``: the goal computations; ``topic_readers``: the topics to the blackboard).
"""
