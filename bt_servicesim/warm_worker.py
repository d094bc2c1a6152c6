"""``python -m bt_servicesim.warm_worker``: one simulator and one executive, episode after episode.

An evaluation's warm pair (docs/reference/evaluation.md, "Warm episodes"). A cold episode is a whole
``python -m bt_servicesim.run``: two interpreters and their imports, DDS discovery between them,
the waits for the simulator's servers, the teardown -- about two thirds of a short mission's
wall time. This process pays that once: it claims a ROS domain, starts its simulator, brings
rclpy up, and then plays the episodes it is sent one after the other. For each it

1. resets the simulator to the episode's world, seed and knobs (``/servicesim/reset``,
   docs/reference/simulator.md, "Episode reset"), which rebuilds the episode exactly as a start
   would;
2. runs the mission as ``run`` does (:class:`~bt_servicesim.mission.run.MissionRun`), on a new
   executive node with a new tree, blackboard and clients, with the process's output going to
   the episode's ``run.log``, and writes the same ``report.json`` and records, with the
   episode's run id;
3. destroys the node and clears the blackboard, so nothing of the episode is left for the next.

Episodes come on stdin, one JSON object a line (:class:`WarmEpisode`); each gets one JSON line
on the reply pipe (``--reply-fd``): ``{"run_id": ..., "exit_code": ..., "goes_on": ...}``
(``goes_on`` false: the worker exits after this episode, its simulator gone), after a first
``{"ready": true, "ros_domain_id": ...}`` once the simulator is up. End of input ends the
worker; so does a stop signal (the episode under way is stopped as ``run`` stops, its report
says ``interrupted``), and a simulator that died (the reply says so, the worker exits 1: the
evaluation replaces the pair).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from bt_servicesim.cli import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, OneLineArgumentParser
from bt_servicesim.mission.settings import (
    DEFAULT_TIME_LIMIT_S,
    STARTUP_LIMIT_S,
    TRAJECTORY_POLICIES,
    RunSettings,
)
from bt_servicesim.mission.stopping import StopSignals, Terminated, exit_code_for
from bt_servicesim.ros.domain import NoFreeDomainError, claim_domain
from bt_servicesim.ros.environment import (
    apply_localhost_defaults,
    end_keeping_the_participant,
)
from bt_servicesim.tree.files import DEFAULT_TREE, nav_params_for
from bt_servicesim.tree.loading import MissionTreeError

if TYPE_CHECKING:  # rclpy is imported once the worker runs ROS
    from rclpy.client import Client
    from rclpy.task import Future
    from servicesim_competition.srv import ResetEpisode

    from bt_servicesim.mission.simulator_process import SimulatorProcess

PROG = "python -m bt_servicesim.warm_worker"
RESET_SERVICE = "/servicesim/reset"
RESET_WAIT_S = 30.0
"""Wall seconds a reset may take to be answered (it loads the world and draws the task)."""
IDLE_HOLD_S = 3600.0
"""The simulator's first hold, until the first reset: no episode is played before one."""


@dataclass(frozen=True)
class WarmEpisode:
    """One episode as the evaluation sends it: what a run's command line would say."""

    out: Path
    run_id: str
    executive: str
    seed: int | None
    speed: float
    time_limit_s: float = DEFAULT_TIME_LIMIT_S
    sim_args: tuple[str, ...] = ()
    tree: Path = DEFAULT_TREE
    nav_params: Path | None = None
    """The robot's navigation parameters file, as the run's ``--nav-params``."""
    trajectory: str = "failed"
    """When the run draws ``trajectory.png``, as the run's ``--trajectory``."""

    @classmethod
    def from_line(cls, line: str) -> WarmEpisode:
        """The episode a line describes; ValueError naming what is wrong with it."""
        fields = json.loads(line)
        if not isinstance(fields, dict):
            raise ValueError("an episode is a JSON object")
        try:
            seed = fields.get("seed")
            episode = cls(out=Path(fields["out"]), run_id=str(fields["run_id"]),
                          executive=str(fields["executive"]),
                          seed=None if seed is None else int(seed),
                          speed=float(fields["speed"]),
                          time_limit_s=float(fields.get("time_limit_s", DEFAULT_TIME_LIMIT_S)),
                          sim_args=tuple(str(arg) for arg in fields.get("sim_args", ())),
                          tree=Path(fields.get("tree") or DEFAULT_TREE),
                          nav_params=nav_params_for(str(fields["executive"]),
                                                    fields.get("nav_params")),
                          trajectory=str(fields.get("trajectory", "failed")))
        except (KeyError, TypeError) as error:
            raise ValueError(f"an episode needs out, run_id, executive and speed: {error}") \
                from error
        if episode.trajectory not in TRAJECTORY_POLICIES:
            raise ValueError(f"trajectory {episode.trajectory!r}: one of "
                             f"{', '.join(TRAJECTORY_POLICIES)}")
        return episode

    def reset_arguments(self) -> list[str]:
        """The simulator's arguments for this episode, as a cold run starts it with."""
        from bt_servicesim.mission.simulator_process import simulator_arguments

        seed = [] if self.seed is None else ["--seed", str(self.seed)]
        return ["--speed", repr(self.speed), *seed,
                *simulator_arguments(self.run_settings(), self.sim_args)]

    def run_settings(self) -> RunSettings:
        return RunSettings(world=None, seed=self.seed, speed=self.speed, tree=self.tree,
                           out=self.out, time_limit_s=self.time_limit_s, headless=True,
                           executive=self.executive, run_id=self.run_id,
                          trajectory=self.trajectory,
                           nav_params=self.nav_params)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Play the episodes given on stdin, one JSON object a line, with one simulator and one "
        "executive process (an evaluation's warm pair)."))
    parser.add_argument("--log-dir", type=Path, required=True,
                        help="where the worker's own and its simulator's output go")
    parser.add_argument("--reply-fd", type=int, required=True,
                        help="an open file descriptor the replies are written to")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        replies = os.fdopen(args.reply_fd, "w", buffering=1)
        args.log_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    apply_localhost_defaults()
    try:
        claim = claim_domain()
    except NoFreeDomainError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return EXIT_FAILED
    os.environ["ROS_DOMAIN_ID"] = str(claim.domain_id)
    try:
        with StopSignals():
            return WarmWorker(log_dir=args.log_dir, replies=replies).serve(sys.stdin)
    except (KeyboardInterrupt, Terminated) as stop:
        return exit_code_for(stop)
    finally:
        claim.release()


class WarmWorker:
    """The simulator process, rclpy and the reset client; :meth:`serve` plays the episodes."""

    def __init__(self, *, log_dir: Path, replies: TextIO) -> None:
        from bt_servicesim.mission.simulator_process import SimulatorProcess

        self.replies = replies
        self.lost: str | None = None
        """Why the simulator can no longer be trusted (it died, or a reset went unanswered)."""
        self.simulator = SimulatorProcess(
            world=None, seed=None, speed=1.0, log_path=log_dir / "sim.log",
            extra_args=("--await-lockstep", f"{IDLE_HOLD_S:.0f}"))

    def serve(self, episodes: TextIO) -> int:
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        self.simulator.start()
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        try:
            with _Resets() as resets:
                if not resets.wait_for_service(self.simulator):
                    print(f"{PROG}: error: the simulator did not come up: "
                          f"{self.simulator.describe_exit()}", file=sys.stderr)
                    return EXIT_FAILED
                self._reply({"ready": True, "ros_domain_id": int(os.environ["ROS_DOMAIN_ID"])})
                return self._play_all(episodes, resets)
        finally:
            self.simulator.stop()
            rclpy.try_shutdown()

    def _play_all(self, episodes: TextIO, resets: _Resets) -> int:
        for line in episodes:
            try:
                episode = WarmEpisode.from_line(line)
            except ValueError as error:
                self._reply({"error": f"not an episode: {error}"})
                continue
            code = self._play(episode, resets)
            if self.lost is None and self.simulator.exit_code() is not None:
                self.lost = self.simulator.describe_exit()
            self._reply({"run_id": episode.run_id, "exit_code": code,
                         "goes_on": self.lost is None and code < 128})
            if code >= 128:  # stopped by a signal: so is the worker
                return code
            if self.lost is not None:
                print(f"{PROG}: error: {self.lost}", file=sys.stderr)
                if self.simulator.killed():  # deleting the participant could crash the worker
                    end_keeping_the_participant(EXIT_FAILED)
                return EXIT_FAILED
        return EXIT_OK

    def _play(self, episode: WarmEpisode, resets: _Resets) -> int:
        """Reset the simulator and run the episode's mission; the run's exit status."""
        from bt_servicesim.mission.run import MissionRun
        from bt_servicesim.run import executive_factory

        episode.out.mkdir(parents=True, exist_ok=True)
        with _output_to(episode.out / "run.log"):
            try:
                asked = resets.ask(episode.reset_arguments())
                settings = episode.run_settings()
                make_executive = executive_factory(settings)  # while the simulator resets
                refused = resets.answer(asked, self.simulator)
                if refused is not None:
                    print(f"{PROG}: error: the simulator refused the reset: {refused}",
                          file=sys.stderr)
                    return EXIT_BAD_INPUT
                run = MissionRun(settings=settings, make_executive=make_executive,
                                 extra_sim_args=episode.sim_args, backend=self.simulator)
                return run.play()
            except SimulatorLostError as lost:
                self.lost = str(lost)
                print(f"{PROG}: error: {lost}", file=sys.stderr)
                return EXIT_FAILED
            except MissionTreeError as error:
                print(f"{PROG}: error: {error}", file=sys.stderr)
                return EXIT_BAD_INPUT
            finally:
                _forget_the_episode()

    def _reply(self, fields: dict[str, Any]) -> None:
        self.replies.write(json.dumps(fields) + "\n")
        self.replies.flush()


class _Resets:
    """A node of the worker's own with the reset client; it lives as long as the worker."""

    def __enter__(self) -> _Resets:
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from servicesim_competition.srv import ResetEpisode

        self.node = Node("bt_servicesim_warm_worker", start_parameter_services=False)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.client: Client[ResetEpisode.Request, ResetEpisode.Response] = (
            self.node.create_client(ResetEpisode, RESET_SERVICE))
        self.request_type = ResetEpisode.Request
        return self

    def __exit__(self, *_: object) -> None:
        self.executor.shutdown()
        self.node.destroy_node()

    def wait_for_service(self, simulator: SimulatorProcess) -> bool:
        deadline = time.monotonic() + STARTUP_LIMIT_S
        while not self.client.service_is_ready():
            if simulator.exit_code() is not None or time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.05)
        return True

    def ask(self, arguments: list[str]) -> Future[ResetEpisode.Response]:
        """Ask the simulator to reset to these arguments; the answer's future."""
        return self.client.call_async(self.request_type(arguments=arguments))

    def answer(self, future: Future[ResetEpisode.Response],
               simulator: SimulatorProcess) -> str | None:
        """None once the reset asked for is done, else the simulator's refusal;
        :class:`SimulatorLostError` if it died or did not answer."""
        deadline = time.monotonic() + RESET_WAIT_S
        while not future.done():
            if simulator.exit_code() is not None:
                raise SimulatorLostError(simulator.describe_exit())
            if time.monotonic() > deadline:
                raise SimulatorLostError(f"the simulator did not answer the reset within "
                                     f"{RESET_WAIT_S:.0f} s")
            self.executor.spin_once(timeout_sec=0.05)
        answer = future.result()
        if answer is None:
            raise SimulatorLostError("the simulator's reset service failed")
        return None if answer.accepted else answer.error


class SimulatorLostError(RuntimeError):
    """The simulator died or stopped answering: the worker cannot play on with it."""


@contextlib.contextmanager
def _output_to(path: Path) -> Iterator[None]:
    """The process's stdout and stderr (file descriptors 1 and 2) go to ``path`` meanwhile."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with path.open("ab") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
    try:
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for duplicate in saved:
            os.close(duplicate)


def _forget_the_episode() -> None:
    """Nothing of the episode for the next: py_trees' blackboard is process-wide."""
    from py_trees.blackboard import Blackboard

    Blackboard.clear()


if __name__ == "__main__":
    sys.exit(main())
