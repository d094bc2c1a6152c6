"""The competition's rules and the robot's figures, as the original ServiceSim states them.

Every number here is a fact of OSRF's ServiceSim (the referee's checkpoints and penalties, the
guest's and the sensors' behaviour, the servicebot's navigation settings), taken from the
reference README (``shared/reference/servicesim/README.md``) and, through it, from the
original's source. This module is the one place the executive reads them from: a planning or
behaviour module that needs a rule imports it from here, and derives its own margins from it
(``PICKUP_REACH`` below is the referee's range less the navigation's tolerance, never a second
literal). The executive's own choices -- clearances, weights, search spacing -- stay with the
algorithm they shape.

The simulator keeps its own copy of the rules it plays (it never imports the executive); they
agree because both come from the same reference.
"""

from __future__ import annotations

__all__ = [
    "FOLLOW_GAP",
    "GOAL_TOLERANCE",
    "GUEST_LOST_DISTANCE",
    "GUEST_SPAWN_PADDING",
    "OBJECT_APPROXIMATION_RADIUS",
    "PEOPLE_LANE_HALF_WIDTH",
    "PEOPLE_LANE_LENGTH",
    "PERSON_APPROXIMATION_RADIUS",
    "PERSON_BODY_RADIUS",
    "PICKUP_RANGE",
    "PICKUP_REACH",
    "RFID_PERIOD",
    "RFID_RANGE",
    "RFID_SILENCE_MEANS_NOBODY",
    "ROBOT_FOOTPRINT",
    "ROBOT_NAME",
]

# ---------------------------------------------------------------------------- the referee
PICKUP_RANGE = 2.0
"""Metres (XY) within which the referee hands the guest over (checkpoint 2)."""
PERSON_APPROXIMATION_RADIUS = 0.75
"""Radius of the ghost cylinder on the robot's base that books approximation to a person."""
OBJECT_APPROXIMATION_RADIUS = 0.35
"""Radius of the ghost cylinder that books approximation to an object (a wall, furniture)."""
ROBOT_NAME = "servicebot"
"""The robot's name in a ``PickUpGuest`` request."""

# ---------------------------------------------------------------------------- the guest
GUEST_SPAWN_PADDING = 1.0
"""The guest spawns at a random point of the pick-up box shrunk by this on every side."""
FOLLOW_GAP = 1.2
"""A following guest stops this far from the robot."""
GUEST_LOST_DISTANCE = 4.0
"""A guest this far behind the robot stops following (the task goes back to checkpoint 2)."""

# ---------------------------------------------------------------------------- other people
PERSON_BODY_RADIUS = 0.25
"""Metres round a person's centre that their body takes (the lidar sees a person about this
wide, and the referee's contact penalty starts at their body)."""
PEOPLE_LANE_HALF_WIDTH = 0.6
"""A walker stops while anyone stands in a lane this many metres either side of its way (and
:data:`PEOPLE_LANE_LENGTH` ahead), and waits as long as it stays blocked
(``TrajectoryActorPlugin.cc``)."""
PEOPLE_LANE_LENGTH = 1.5
"""Metres ahead of a walker that its lane reaches (measured in 3-D from its origin, 1 m up, so
the robot on the floor holds it up from about 1.12 m, a person from the full 1.5 m)."""

# ---------------------------------------------------------------------------- RFID
RFID_RANGE = 2.0
"""Metres (XY) within which RFID names a person."""
RFID_PERIOD = 0.1
"""Seconds between RFID messages (10 Hz) while anybody is in range."""
RFID_SILENCE_MEANS_NOBODY = 2.0
"""The sensor publishes nothing while nobody is in range; OSRF's later solution took 2 s of
silence to mean the guest was lost."""

# ---------------------------------------------------------------------------- the servicebot
GOAL_TOLERANCE = 0.3
"""Navigation's goal tolerance in metres: a goal succeeds this close to it."""
ROBOT_FOOTPRINT = (0.4, 0.5)
"""The robot's footprint in metres (length, width)."""

# ---------------------------------------------------------------------------- derived
PICKUP_REACH = PICKUP_RANGE - GOAL_TOLERANCE
"""A pick-up spot counts as in reach of a goal this close: the referee's range less the
distance by which navigation may stop short of the goal."""
