"""The simulator's markers on ROS: ``visualization_msgs/MarkerArray`` in the ``map`` frame.

Two topics, so that a viewer that joins late, or a recording opened at any moment, still has
the building:

* ``/servicesim/markers/areas``: the target areas and their names, published once, latched
  (transient local), as a map is;
* ``/servicesim/markers``: the people, the guest and the robot's planned path, with the actors
  (every 0.5 sim s); only what :class:`~servicesim_sim.model.markers.SceneTracker` says changed is
  deleted, the people are sent every time (they move).

What is drawn and how is :mod:`servicesim_sim.model.markers`; this module only publishes the
messages, as CDR bytes serialised by hand (:mod:`servicesim_sim.wire.marker_messages`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Time
from visualization_msgs.msg import MarkerArray

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.markers import SceneTracker, areas_update
from servicesim_sim.wire.marker_messages import MarkerArrayBytes

MARKERS_TOPIC = "/servicesim/markers"
AREA_MARKERS_TOPIC = "/servicesim/markers/areas"


class MarkerTopics:
    """Publishes the engine's scene: the areas at once, the rest on each :meth:`publish`.

    ``make_publisher(type, topic, qos)`` is the node's (the simulator's own wrapper);
    ``send(publisher, message)`` its guarded publish.
    """

    def __init__(self, *, engine: SimEngine, make_publisher: Callable[..., Any],
                 send: Callable[[Any, Any], None], latched: Any, now: Time) -> None:
        self.engine = engine
        self._send = send
        self._scene = make_publisher(MarkerArray, MARKERS_TOPIC, 10)
        self._areas = make_publisher(MarkerArray, AREA_MARKERS_TOPIC, latched)
        self._tracker = SceneTracker()
        self._encoder = MarkerArrayBytes()
        task = engine.scenario.task
        roles = {task.pick_up: "pick-up", task.drop_off: "drop-off", task.start_area: "start"}
        areas = areas_update(engine.world.areas, roles=roles)
        send(self._areas, MarkerArrayBytes().encode(areas, stamp=(now.sec, now.nanosec)))

    def publish(self, now: Time) -> None:
        """The people, the guest and (when it changed) the plan, as they are now."""
        navigator = self.engine.navigator
        plan = navigator.path if navigator.status == "running" else []
        update = self._tracker.update(self.engine.people_states(), plan)
        self._send(self._scene, self._encoder.encode(update, stamp=(now.sec, now.nanosec)))
