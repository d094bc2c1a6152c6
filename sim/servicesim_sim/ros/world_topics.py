"""The world's topics: the map, navigation's global costmap, the referee's state, score and
penalties by cause, the people, and the markers a viewer draws.

Design intent: each goes out at its own rate, counted in I/O periods: the map once (latched),
the referee's state and the people every 0.5 sim s (the referee's state also as soon as it
changes), the costmap every sim second as Nav2 publishes it, the score once per physics step
but sent with the period's ``/clock``. What nobody subscribes to (the score, the costmap) is
not built. The referee's state and the people are serialised by hand
(:mod:`servicesim_sim.wire.world_messages`).
"""

from __future__ import annotations

import array

from nav_msgs.msg import OccupancyGrid
from servicesim_competition.msg import ActorStates, RefereeState, Score

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.ros.marker_topics import MarkerTopics
from servicesim_sim.ros.penalty_causes import PenaltyCausesTopic
from servicesim_sim.ros.publishing import LATCHED, Publishing, stamp
from servicesim_sim.wire.costmap_message import OccupancyValues, serialised_occupancy_grid
from servicesim_sim.wire.world_messages import ActorStatesBytes, RefereeStateBytes
from servicesim_sim.world.files import World

PUBLIC_PERIOD_STEPS = 5  # referee state and people every 0.5 s sim
COSTMAP_PERIOD_STEPS = 10  # the global costmap every 1 s sim: Nav2's publish_frequency 1.0
GLOBAL_COSTMAP_TOPIC = "/servicebot/global_costmap/costmap"


class WorldTopics:
    """Publishes the map, the costmap, the referee and the people at their rates."""

    def __init__(self, *, engine: SimEngine, world: World, publishing: Publishing) -> None:
        self.engine = engine
        self.world = world
        self._send = send = publishing.send
        publisher = publishing.publisher
        self._score = publisher(Score, "/servicesim/score", 10)
        self._referee = publisher(RefereeState, "/servicesim/referee", LATCHED)
        self.actors = publisher(ActorStates, "/servicesim/actors", 10)
        self._map = publisher(OccupancyGrid, "/servicebot/map", LATCHED)
        self._costmap = publisher(OccupancyGrid, GLOBAL_COSTMAP_TOPIC, LATCHED)
        self._markers = MarkerTopics(engine=engine, make_publisher=publisher, send=send,
                                     latched=LATCHED, now=stamp(engine.sim_time))
        self._penalty_causes = PenaltyCausesTopic(engine=engine, make_publisher=publisher,
                                                  send=send, latched=LATCHED)
        self._score_message = Score()  # refilled: publish serialises at the call
        self._costmap_values: OccupancyValues | None = None  # made at the first costmap sent
        self._actors_bytes: tuple[tuple[str, ...], ActorStatesBytes] | None = None
        self._referee_bytes: RefereeStateBytes | None = None

    def send_map(self) -> None:
        self._send(self._map, self._map_message())

    def publish(self, *, io_count: int) -> None:
        """What is due in I/O period number ``io_count`` (counted from 1)."""
        if io_count % PUBLIC_PERIOD_STEPS == 0 or self.engine.referee_changed():
            self._send(self._referee, self._referee_state())
        self._penalty_causes.publish()
        if io_count % PUBLIC_PERIOD_STEPS == 0:
            self._send(self.actors, self._actor_states())
            self._markers.publish(stamp(self.engine.sim_time))
        if io_count % COSTMAP_PERIOD_STEPS == 0:
            self._publish_costmap()

    def scores_read(self) -> bool:
        """Whether anyone subscribes to the score: the loop works the scores out only then
        (the run records the referee's state, which carries the score)."""
        return bool(self._score.get_subscription_count() > 0)

    def publish_scores(self, scores: list[float]) -> None:
        """The period's score messages, one per physics step (50 Hz sim) of a running task,
        sent together (none when nobody read the score as the period began).

        Sent with the period's /clock rather than as each step ends: a client's clock moves
        only with /clock, so it cannot tell the difference, and a burst wakes it once where
        five messages spread over the period woke it up to five times.
        """
        for score in scores:
            self._score_message.score = score
            self._send(self._score, self._score_message)

    def _publish_costmap(self) -> None:
        """Navigation's costmap as Nav2's global costmap publishes it (``map`` frame, values
        by Nav2's table), only while someone listens; serialised here
        (:mod:`servicesim_sim.wire.costmap_message`).

        The people on it are where the lidar marked them. Nav2 places marks by the robot's
        estimated pose; this costmap places them where people stand (docs/fidelity.md)."""
        if self._costmap.get_subscription_count() == 0:
            return
        costmap = self.engine.navigator.costmap
        if self._costmap_values is None:
            self._costmap_values = OccupancyValues(costmap.static)
        now = stamp(self.engine.sim_time)
        self._send(self._costmap, serialised_occupancy_grid(
            self._costmap_values.of(costmap.costs()), costmap.frame, frame_id="map",
            stamp=(now.sec, now.nanosec)))

    def _map_message(self) -> OccupancyGrid:
        occupancy = self.world.map
        message = OccupancyGrid()
        message.header.frame_id = "map"
        message.info.resolution = float(occupancy.resolution)
        message.info.width, message.info.height = occupancy.width, occupancy.height
        message.info.origin.position.x = float(occupancy.origin_x)
        message.info.origin.position.y = float(occupancy.origin_y)
        message.info.origin.orientation.w = 1.0
        message.data = array.array("b", occupancy.grid.astype("int8").ravel().tobytes())
        return message

    def _referee_state(self) -> bytes:
        report = self.engine.referee_report()
        checkpoints = report["checkpoints"]
        if self._referee_bytes is None:  # the checkpoints' names never change
            self._referee_bytes = RefereeStateBytes(names=[c["name"] for c in checkpoints])
        now = stamp(self.engine.sim_time)
        penalties = report["penalties"]
        return self._referee_bytes.encode(
            stamp=(now.sec, now.nanosec), running=bool(report["running"]),
            completed=bool(report["completed"]), score=float(report["score"]),
            task_sim_time=float(report["task_sim_time"]),
            done=[bool(c["done"]) for c in checkpoints],
            times=[float(c["sim_time_s"]) for c in checkpoints],
            counts=(int(penalties["failed_pickup"]), int(penalties["failed_dropoff"]),
                    int(penalties["too_fast"]), int(penalties["drifts"])),
            contact=float(penalties["contact"]), approximation=float(penalties["approximation"]))

    def _actor_states(self) -> bytes:
        """Everyone's place."""
        states = self.engine.people_states()
        names = tuple(name for name, _, _, _ in states)
        if self._actors_bytes is None or self._actors_bytes[0] != names:
            self._actors_bytes = (names, ActorStatesBytes(
                names=names, roles=[role for _, role, _, _ in states]))
        now = stamp(self.engine.sim_time)
        return self._actors_bytes[1].encode(
            stamp=(now.sec, now.nanosec), positions=[(x, y) for _, _, x, y in states],
            guest_state=self.engine.guest_state())
