"""The referee: the competition's checkpoints, penalties and score, as the original counted them.

The task has four checkpoints, done in order: go to the pick-up area, pick up the guest, drop
them off, return to the start. Each accrues the sim seconds during which it is the current one;
the score is the weighted sum of those times plus the penalties (lower is better):

======================  =====================================================
checkpoint time          × 1 (CP1), × 2 (CP2), × 2 (CP3), × 1 (CP4)
failed pick-up           40 each
failed drop-off          50 each
guest lost "too fast"    25 each
contact                  40000 × depth (a person), 20000 × depth (an object)
approximation            1 × depth of the 0.75 m ghost cylinder into a person,
                         0.25 × depth of the 0.35 m ghost cylinder into an object
======================  =====================================================

The original's contact sensors reported at the physics rate, 500 Hz, and each report added
weight × penetration depth (``PenaltyChecker.cc``). The simulator steps more coarsely, so a step
of ``dt`` seconds adds ``500 · dt`` reports' worth: the penalty per sim second is the original's
for the same depth.

Penalties are booked from the start of the world, not from ``new_task``, as the original's
were: its contact checker ran from the start, and a pick-up or drop-off called before the task
booked its failed-attempt points on a checkpoint that had not started; both count in the score
once it starts. Nothing is booked once the task has completed.

Contact and approximation points are also kept by **cause**, running sums for the run's
records (:attr:`Penalties.by_cause`): ``approximation/ROLE/NAME`` for the depth into a person
(role ``guest``, ``walker`` or ``idler``), ``approximation/walls`` for the depth into the
nearest wall; ``contact/...`` the same. They are booked here, with the totals, from the depths
the engine took, so they add up to the totals (to rounding) and nothing is reconstructed later.

A drift or a guest lost "too fast" during checkpoint 3 sends the task back to checkpoint 2. The
referee only keeps the books; the engine decides what happened and asks it to record it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TypedDict

CHECKPOINT_NAMES = ("go_to_pick_up", "pick_up_guest", "drop_off_guest", "return_to_start")
CHECKPOINT_WEIGHTS = (1.0, 2.0, 2.0, 1.0)
FAILED_PICKUP_PENALTY = 40.0
FAILED_DROPOFF_PENALTY = 50.0
TOO_FAST_PENALTY = 25.0
CONTACT_REPORT_RATE_HZ = 500.0
PERSON_CONTACT_WEIGHT = 40000.0
OBJECT_CONTACT_WEIGHT = 20000.0
PERSON_APPROXIMATION_WEIGHT = 1.0
OBJECT_APPROXIMATION_WEIGHT = 0.25

GO_TO_PICK_UP, PICK_UP_GUEST, DROP_OFF_GUEST, RETURN_TO_START = range(4)


class CheckpointReport(TypedDict):
    """One checkpoint in :meth:`Referee.report`."""

    name: str
    done: bool
    sim_time_s: float


class PenaltyReport(TypedDict):
    """The penalties in :meth:`Referee.report`: counts, and the points of contact and
    approximation."""

    failed_pickup: int
    failed_dropoff: int
    too_fast: int
    drifts: int
    contact: float
    approximation: float


class RefereeReport(TypedDict):
    """The referee's account, in report.json's shape."""

    running: bool
    completed: bool
    score: float
    task_sim_time: float
    checkpoints: list[CheckpointReport]
    penalties: PenaltyReport


@dataclass
class Penalties:
    failed_pickup: int = 0
    failed_dropoff: int = 0
    too_fast: int = 0
    drifts: int = 0
    contact: float = 0.0
    approximation: float = 0.0
    by_cause: dict[str, float] = field(default_factory=dict)
    """Contact and approximation points by cause (see the module docstring), running sums."""
    bookings: int = 0
    """How many steps booked contact or approximation points: changes when ``by_cause`` does."""

    def points(self) -> float:
        return (self.failed_pickup * FAILED_PICKUP_PENALTY
                + self.failed_dropoff * FAILED_DROPOFF_PENALTY
                + self.too_fast * TOO_FAST_PENALTY + self.contact + self.approximation)


@dataclass
class Referee:
    """The books of one task; :meth:`start` opens them, :meth:`advance` runs the clock."""

    running: bool = False
    started: bool = False
    completed: bool = False
    current: int = GO_TO_PICK_UP
    elapsed: float = 0.0
    checkpoint_times: list[float] = field(default_factory=lambda: [0.0] * 4)
    checkpoint_done: list[bool] = field(default_factory=lambda: [False] * 4)
    penalties: Penalties = field(default_factory=Penalties)
    revision: int = 0  # bumped on every event, so observers can tell something changed

    def start(self) -> None:
        self.running = self.started = True
        self.revision += 1

    def advance(self, dt: float) -> None:
        """Count ``dt`` sim seconds against the current checkpoint."""
        if self.running:
            self.elapsed += dt
            self.checkpoint_times[self.current] += dt

    def reach(self, checkpoint: int) -> None:
        """The current checkpoint is done; the task completes after the fourth."""
        assert checkpoint == self.current and self.running
        self.checkpoint_done[checkpoint] = True
        self.revision += 1
        if checkpoint == RETURN_TO_START:
            self.running, self.completed = False, True
        else:
            self.current = checkpoint + 1

    def guest_stopped_following(self, *, too_fast: bool) -> None:
        """The guest drifted or fell behind. During checkpoint 3 that sends the task back to
        checkpoint 2 (and "too fast" costs its penalty); at other times (a guest picked up
        again after the drop-off) it changes nothing but the drift count."""
        if not too_fast:
            self.penalties.drifts += 1
        if self.running and self.current == DROP_OFF_GUEST:
            if too_fast:
                self.penalties.too_fast += 1
            self.checkpoint_done[PICK_UP_GUEST] = False
            self.current = PICK_UP_GUEST
        self.revision += 1

    def checkpoint_started(self, checkpoint: int) -> bool:
        """Whether the task has reached ``checkpoint`` (done or current), ever."""
        return self.started and (self.completed or self.current >= checkpoint)

    def failed_pickup(self) -> None:
        self.penalties.failed_pickup += 1
        self.revision += 1

    def failed_dropoff(self) -> None:
        self.penalties.failed_dropoff += 1
        self.revision += 1

    def contact(self, *, person_depth: float, object_depth: float, dt: float,
                people: Sequence[tuple[str, float]] = ()) -> None:
        """Book a step's contact; ``people``: each person's cause (``ROLE/NAME``) and depth,
        adding up to ``person_depth``, for the books by cause."""
        if not self.completed and (person_depth > 0.0 or object_depth > 0.0):
            reports = CONTACT_REPORT_RATE_HZ * dt
            self.penalties.contact += reports * (PERSON_CONTACT_WEIGHT * person_depth
                                                 + OBJECT_CONTACT_WEIGHT * object_depth)
            self._by_cause("contact", reports * PERSON_CONTACT_WEIGHT, people,
                           reports * OBJECT_CONTACT_WEIGHT * object_depth)

    def approximation(self, *, person_depth: float, object_depth: float, dt: float,
                      people: Sequence[tuple[str, float]] = ()) -> None:
        """Book a step's approximation; ``people`` as for :meth:`contact`."""
        if not self.completed and (person_depth > 0.0 or object_depth > 0.0):
            reports = CONTACT_REPORT_RATE_HZ * dt
            self.penalties.approximation += reports * (
                PERSON_APPROXIMATION_WEIGHT * person_depth
                + OBJECT_APPROXIMATION_WEIGHT * object_depth)
            self._by_cause("approximation", reports * PERSON_APPROXIMATION_WEIGHT, people,
                           reports * OBJECT_APPROXIMATION_WEIGHT * object_depth)

    def _by_cause(self, penalty: str, per_depth: float, people: Sequence[tuple[str, float]],
                  walls: float) -> None:
        books = self.penalties.by_cause
        for who, depth in people:
            if depth > 0.0:
                cause = f"{penalty}/{who}"
                books[cause] = books.get(cause, 0.0) + per_depth * depth
        if walls > 0.0:
            cause = f"{penalty}/walls"
            books[cause] = books.get(cause, 0.0) + walls
        self.penalties.bookings += 1

    def score(self) -> float:
        timed = sum(weight * seconds
                    for weight, seconds in zip(CHECKPOINT_WEIGHTS, self.checkpoint_times,
                                               strict=True))
        return timed + self.penalties.points()

    def report(self) -> RefereeReport:
        """The referee's account, in report.json's shape."""
        return {
            "running": self.running,
            "completed": self.completed,
            "score": round(self.score(), 6),
            "task_sim_time": round(self.elapsed, 6),
            "checkpoints": [
                {"name": name, "done": done, "sim_time_s": round(seconds, 6)}
                for name, done, seconds in zip(CHECKPOINT_NAMES, self.checkpoint_done,
                                               self.checkpoint_times, strict=True)
            ],
            "penalties": {
                "failed_pickup": self.penalties.failed_pickup,
                "failed_dropoff": self.penalties.failed_dropoff,
                "too_fast": self.penalties.too_fast,
                "drifts": self.penalties.drifts,
                "contact": round(self.penalties.contact, 6),
                "approximation": round(self.penalties.approximation, 6),
            },
        }
