"""The competition's task on the world: the referee's services and the checks of every step,
with no ROS in it.

The services play the original's rules (``Checkpoint.cc``, ``CP_PickUp.cc``, ``CP_DropOff.cc``,
``FollowActorPlugin.cc``): a pick-up or drop-off before its checkpoint started is a failed
attempt (before ``new_task`` too); one after its checkpoint is done answers success with no
penalty, and still acts on the guest (a pick-up within reach makes them follow again, a
drop-off makes them stop); ``drift`` always answers true and arms a drift that fires once the
guest follows and is more than 1.2 m from the robot. Each step the referee checks the
checkpoints that depend on where things are (1 and 4), and the guest drifts at the scheduled
world times or stops following when left too far behind.

Design intent: :class:`TaskRules` says what the referee's rules do to the guest and the books;
the engine (:mod:`servicesim_sim.model.engine`) steps the world and hands the rules its sim
time.
"""

from __future__ import annotations

from collections.abc import Iterable

from servicesim_sim.model import referee as rules
from servicesim_sim.model.guest import (
    DRIFT_TIME_TOLERANCE,
    LOST_DISTANCE,
    STOP_DISTANCE,
    Guest,
    GuestState,
)
from servicesim_sim.model.referee import Referee
from servicesim_sim.model.robot import Robot
from servicesim_sim.world.files import TaskSpec, World

__all__ = ["PICKUP_RANGE_M", "ROBOT_NAME", "TaskRules"]

ROBOT_NAME = "servicebot"
PICKUP_RANGE_M = 2.0


class TaskRules:
    """``task`` in ``world``, refereed by ``referee``; drifts due at ``drift_times`` (sim s)."""

    def __init__(self, *, referee: Referee, guest: Guest, robot: Robot, world: World,
                 task: TaskSpec, drift_times: Iterable[float]) -> None:
        self.referee, self.guest, self.robot = referee, guest, robot
        self.world, self.task = world, task
        self.started_at: float | None = None
        """The sim time of ``new_task``; None before it."""
        self._drifts = list(drift_times)
        self._drift_armed = False

    def new_task(self, *, now: float) -> tuple[bool, str]:
        if self.referee.started:
            state = "is running" if self.referee.running else "has ended"
            return False, f"a task {state}; one task per simulator run"
        self.referee.start()
        self.started_at = now
        self.check_areas()
        return True, "task started"

    def pickup(self, guest_name: str, robot_name: str) -> tuple[bool, str]:
        referee = self.referee
        if not referee.checkpoint_started(rules.PICK_UP_GUEST):
            referee.failed_pickup()  # booked even before new_task; scored once it starts
            return False, ("no task is running" if not referee.started
                           else "checkpoint 1 (reach the pick-up area) is not done")
        if referee.checkpoint_done[rules.PICK_UP_GUEST]:
            return True, self._pick_up_again(guest_name, robot_name)
        reason = self._pickup_refusal(guest_name, robot_name)
        if reason:
            referee.failed_pickup()
            return False, reason
        self.guest.start_following(self.robot.x, self.robot.y)
        referee.reach(rules.PICK_UP_GUEST)
        return True, f"{guest_name} follows {robot_name}"

    def _pick_up_again(self, guest_name: str, robot_name: str) -> str:
        """Checkpoint 2 is done: the answer is success whatever happens; the guest follows
        (again) only if the names are right and the robot is within reach."""
        if self._pickup_refusal(guest_name, robot_name) or self.guest.following:
            return "checkpoint 2 is done; the guest's state is unchanged"
        self.guest.start_following(self.robot.x, self.robot.y)
        return f"checkpoint 2 is done; {guest_name} follows {robot_name} again"

    def _pickup_refusal(self, guest_name: str, robot_name: str) -> str:
        if robot_name != ROBOT_NAME:
            return f"unknown robot {robot_name!r}"
        if guest_name != self.guest.name:
            return f"{guest_name!r} is not the guest"
        distance = self.guest.distance_to(self.robot.x, self.robot.y)
        if distance > PICKUP_RANGE_M:
            return f"the guest is {distance:.2f} m away (more than {PICKUP_RANGE_M} m)"
        return ""

    def dropoff(self, guest_name: str) -> tuple[bool, str]:
        referee = self.referee
        if referee.checkpoint_done[rules.DROP_OFF_GUEST]:
            if guest_name == self.guest.name and self.guest.following:
                self.guest.stop_following(GuestState.DROPPED_OFF)
            return True, "checkpoint 3 is done"
        reason = self._dropoff_refusal(guest_name)
        if reason:
            referee.failed_dropoff()  # booked even before new_task; scored once it starts
            return False, reason
        self.guest.stop_following(GuestState.DROPPED_OFF)
        referee.reach(rules.DROP_OFF_GUEST)
        return True, f"{guest_name} dropped off in {self.task.drop_off}"

    def _dropoff_refusal(self, guest_name: str) -> str:
        if not self.referee.running:
            return "no task is running"
        if guest_name != self.guest.name:
            return f"{guest_name!r} is not the guest"
        if self.referee.current != rules.DROP_OFF_GUEST or not self.guest.following:
            return "the guest is not following the robot"
        box = self.world.areas[self.task.drop_off]
        if not box.contains(self.guest.x, self.guest.y):
            return (f"the guest at ({self.guest.x:.2f}, {self.guest.y:.2f}) is outside "
                    f"{self.task.drop_off}")
        return ""

    def force_drift(self) -> tuple[bool, str]:
        """The debug ``drift``: always true; the drift fires once the guest follows and is
        more than 1.2 m from the robot (now, or after the next pick-up)."""
        self._drift_armed = True
        return True, "drift armed"

    def check_areas(self) -> None:
        """Checkpoints 1 and 4: the robot in the pick-up area, then back in the start area."""
        referee, areas = self.referee, self.world.areas
        x, y = self.robot.x, self.robot.y
        if referee.current == rules.GO_TO_PICK_UP and areas[self.task.pick_up].contains(x, y):
            referee.reach(rules.GO_TO_PICK_UP)
        if (referee.current == rules.RETURN_TO_START
                and areas[self.task.start_area].contains(x, y)):
            referee.reach(rules.RETURN_TO_START)

    def check_guest(self, *, now: float) -> None:
        """The original's order (``FollowActorPlugin.cc``): a guest more than 4 m behind stops
        following ("too fast"); else a drift fires whatever the distance while a scheduled
        world time is within 0.5 s (either side: a guest picked up again inside that second
        drifts again, as the original keeps its times), or, when armed by the ``drift``
        service, once the guest is more than 1.2 m from the robot. A scheduled drift whose
        second passes with nobody following is skipped."""
        guest = self.guest
        while self._drifts and now > self._drifts[0] + DRIFT_TIME_TOLERANCE:
            self._drifts.pop(0)  # its second is over
        due = bool(self._drifts) and now >= self._drifts[0] - DRIFT_TIME_TOLERANCE
        if not guest.following:
            return
        distance = guest.distance_to(self.robot.x, self.robot.y)
        if distance > LOST_DISTANCE:
            guest.stop_following(GuestState.LOST)
            self.referee.guest_stopped_following(too_fast=True)
        elif due or (self._drift_armed and distance > STOP_DISTANCE):
            self._drift_armed = False
            self.guest.stop_following(GuestState.DRIFTED)
            self.referee.guest_stopped_following(too_fast=False)
