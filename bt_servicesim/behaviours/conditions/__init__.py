"""The mission tree's conditions: leaves that only check, SUCCESS or FAILURE, never RUNNING.

Each derives from :class:`~bt_servicesim.behaviours.node.ConditionNode` and implements
``check()``.
"""
