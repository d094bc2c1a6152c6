"""The simulator's ROS 2 node: it owns the engine and its loop, and composes the node's parts.

Everything that happens lives in :class:`~servicesim_sim.model.engine.SimEngine`, stepped at a
fixed physics step in sim time; the node only turns engine state into messages and requests
into engine calls, through its parts: the robot's topics (:mod:`~servicesim_sim.ros.robot_topics`),
the camera (:mod:`~servicesim_sim.ros.camera_topic`), the world's topics
(:mod:`~servicesim_sim.ros.world_topics`), the competition's services
(:mod:`~servicesim_sim.ros.services`), the NavigateToPose action
(:mod:`~servicesim_sim.ros.navigation_action`) and the robot's inputs
(:mod:`~servicesim_sim.ros.robot_inputs`). Its loop steps the engine, publishes ``/clock`` and
the sensors, then lets rclpy handle requests; with a speed factor it waits (serving requests)
until the wall clock catches up, and when it falls behind it slips rather than racing
(:mod:`servicesim_sim.process.pacing`); with speed 0 it never waits. Nothing here reads the
wall clock for simulation purposes.

A client may join the simulator's lockstep (:mod:`servicesim_sim.lockstep.server`): the loop
then announces each period's end, steps the next while the clients tick on it, holds until
every joined client has finished that tick, and serves its requests in a fixed order; the
node's handlers are counted and gated for that, and with nobody joined they run at once.

Every request gets an answer, however many come at once: the services and the action's goal,
cancel and result services hold every request of a burst
(:data:`~servicesim_sim.ros.publishing.EVERY_REQUEST`), and the loop's executor takes all that
wait (:mod:`servicesim_sim.process.executor`).
"""

from __future__ import annotations

import time

import rclpy
from rclpy.node import Node
from rclpy.task import Future

from servicesim_sim.lockstep.server import LockstepServer
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.model.playable import playable_engine
from servicesim_sim.process.executor import DrainingExecutor
from servicesim_sim.process.pacing import Pacer
from servicesim_sim.process.period_costs import PeriodCosts
from servicesim_sim.ros.camera_topic import CameraTopic
from servicesim_sim.ros.episodes import EpisodeResets
from servicesim_sim.ros.navigation_action import NavigationAction
from servicesim_sim.ros.publishing import Publishing, stamp_ns
from servicesim_sim.ros.robot_inputs import RobotInputs
from servicesim_sim.ros.robot_topics import RobotTopics
from servicesim_sim.ros.services import CompetitionServices
from servicesim_sim.ros.sim_sleep import SimSleepers
from servicesim_sim.ros.world_topics import WorldTopics
from servicesim_sim.settings import SimSettings

IO_PERIOD_S = 0.1  # ROS input/output every 0.1 s sim: /clock, odom, RFID at 10 Hz
IDLE_WAIT_S = 0.05  # wall seconds of one wait while an episode is over (see SimulatorNode._idle)


class SimulatorNode:
    """One simulated world on one ROS node; :meth:`run` until interrupted."""

    def __init__(self, settings: SimSettings, *, node: Node,
                 engine: SimEngine | None = None, resets: EpisodeResets | None = None) -> None:
        """``engine``: the world already set in motion for ``settings``; default: made here.
        ``resets``: where an episode reset is asked for; the loop then ends with
        :class:`~servicesim_sim.ros.episodes.ResetRequested` at the end of its period."""
        self.settings = settings
        self.node = node
        self.resets = resets
        self.engine = engine = engine or playable_engine(
            settings.world, seed=settings.seed, difficulty=settings.difficulty)
        self.steps_per_io = max(1, round(IO_PERIOD_S / engine.dt))
        self._io_count = 0
        self._had_client = False
        self.costs = PeriodCosts()
        self.lockstep = lockstep = LockstepServer(node)
        self.publishing = publishing = Publishing(node=node, lockstep=lockstep)
        self.robot_topics = RobotTopics(engine=engine, publishing=publishing)
        self.camera = CameraTopic(engine=engine, rate_hz=settings.camera_rate_hz,
                                  publishing=publishing, lockstep=lockstep)
        self.world_topics = WorldTopics(engine=engine, world=settings.world,
                                        publishing=publishing)
        self.robot_topics.send_static_transforms()
        self.sleepers = SimSleepers(engine=engine, lockstep=lockstep)
        self.services = CompetitionServices(node=node, engine=engine, settings=settings,
                                            lockstep=lockstep, sim_sleep=self.sim_sleep)
        self.navigation = NavigationAction(node=node, engine=engine, world=settings.world,
                                           lockstep=lockstep, io_period_s=IO_PERIOD_S)
        self.inputs = RobotInputs(node=node, engine=engine, lockstep=lockstep)
        self.world_topics.send_map()

    def sim_sleep(self, seconds: float) -> Future[bool]:
        """A future completed by the loop once ``seconds`` of sim time have passed."""
        return self.sleepers.sleep(seconds)

    # ----------------------------------------------------------------- loop
    def run(self, executor: DrainingExecutor) -> None:
        """Step, publish and serve until the context shuts down, paced by the speed factor."""
        pacer = Pacer()
        period = 0
        costs, now = self.costs, self.costs.now
        ended = now()  # each period starts where the last one ended: three clock reads a period
        while rclpy.ok(context=self.node.context):
            started = ended
            self._check_reset()
            task_ran, scores = self._step(scoring=self.world_topics.scores_read())
            stepped = now()
            period += 1
            self.world_topics.publish_scores(scores)
            self._publish_io()
            published = now()
            self._end_period(period, executor)
            self._wait_for_wall_clock(pacer, executor)
            self.lockstep.hold(executor)
            ended = now()
            if task_ran:
                costs.add(started=started, stepped=stepped, published=published, ended=ended)
            self._had_client = self._had_client or self.lockstep.active
            if self._had_client and not self.lockstep.active and self._resets_used():
                self._idle(executor)

    def _step(self, *, scoring: bool) -> tuple[bool, list[float]]:
        """The period's physics steps, each followed by the camera's frame if one is due;
        whether a task ran in any of them, and the score after each step of a running task
        when ``scoring`` (someone reads the score topic)."""
        task_ran = False
        scores: list[float] = []
        for _ in range(self.steps_per_io):
            self.engine.step()
            self.camera.capture()
            if self.engine.task_running():
                task_ran = True
                if scoring:
                    scores.append(float(self.engine.score()))
        return task_ran, scores

    def _publish_io(self) -> None:
        self.robot_topics.publish()
        self._io_count += 1
        self.world_topics.publish(io_count=self._io_count)
        self.camera.publish()

    def _end_period(self, period: int, executor: DrainingExecutor) -> None:
        """Goals and sleeps that ended resume; lockstep announces the period (and at the
        first, with ``--await-lockstep``, holds until a client joins)."""
        goals_ended = self.navigation.advance()
        sleeps_over = self.sleepers.wake(executor)
        if goals_ended or sleeps_over:
            executor.note_resumable()
        self.lockstep.end_period(period=period, sim_time_ns=stamp_ns(self.engine.sim_time),
                                 executor=executor)
        if period == 1 and self.settings.await_lockstep_s > 0.0:
            self.lockstep.await_client(
                executor, wall_s=self.settings.await_lockstep_s,
                meanwhile=self._repeat_clock)

    def _repeat_clock(self) -> None:
        """While the loop holds at its first period for a client: the clock again, for late
        subscribers; a reset asked for meanwhile ends the hold."""
        self._check_reset()
        self.robot_topics.repeat_clock()

    def _check_reset(self) -> None:
        if self.resets is not None:
            self.resets.check()

    def _resets_used(self) -> bool:
        return self.resets is not None and self.resets.used

    def _idle(self, executor: DrainingExecutor) -> None:
        """Hold still, serving requests, until a reset or a new lockstep client.

        Only in a simulator that plays episodes one after another (it has taken a reset):
        once the episode's lockstep client has left, the episode is over, and running on
        flat out until the next reset would only take a core from the episodes running
        beside it.
        """
        while not self.lockstep.active and rclpy.ok(context=self.node.context):
            self._check_reset()
            executor.wait_and_run(timeout_sec=IDLE_WAIT_S)

    def close(self, executor: DrainingExecutor) -> None:
        """Drop what the node's destruction leaves alive: the coroutines waiting on sim time,
        navigation or the gate, which no loop will resume now, and the navigation action
        server (a waitable). Logs what the task's periods cost
        (:mod:`servicesim_sim.process.period_costs`)."""
        self.node.get_logger().info(self.costs.summary())
        executor.drop_tasks_of(self.node)
        self.sleepers.clear()
        self.navigation.close()

    def _wait_for_wall_clock(self, pacer: Pacer, executor: DrainingExecutor) -> None:
        """Serve requests until the speed factor lets the next period start."""
        wait_s = pacer.wait_s(sim_time=self.engine.sim_time, speed=self._pace())
        if wait_s <= 0.0:  # flat out or behind: only look for requests (in lockstep the
            if not self.lockstep.active:  # gate looks, when what it waits for is not in)
                executor.run_ready()
            return
        due = time.monotonic() + wait_s
        while (remaining := due - time.monotonic()) > 0.0:
            executor.wait_and_run(timeout_sec=remaining)

    def _pace(self) -> float:
        """The speed factor now: at most real time until a task starts.

        Before ``new_task`` nothing is scored, and running flat out would only flood the
        machine while the executive starts and DDS discovers its endpoints — a response
        written before the server has matched the client's reader is lost. A lockstep client
        has found its endpoints before it joins, and the gate holds the world for it anyway.
        """
        speed = self.settings.speed
        if self.engine.task_started or self.lockstep.active or 0.0 < speed <= 1.0:
            return speed
        return 1.0
