"""The simulator on ROS: one episode after another on one executor, until a stop signal.

Each episode is a :class:`~servicesim_sim.ros.node.SimulatorNode` on a ROS node of its own; an
accepted reset (:mod:`servicesim_sim.ros.episodes`) ends the episode's loop, drops its node and
starts the next one from the reset's settings. The process's stop signals
(:mod:`servicesim_sim.process.stop_signals`) end the loop and let the shut-down finish.
"""

from __future__ import annotations

import gc
import signal

import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from servicesim_sim.model.engine import SimEngine
from servicesim_sim.process.executor import DrainingExecutor
from servicesim_sim.process.stop_signals import STOP_SIGNALS, handled
from servicesim_sim.ros.episodes import EpisodeResets, ResetRequested, episodes_ros_node
from servicesim_sim.ros.node import SimulatorNode
from servicesim_sim.settings import SimSettings


def simulator_ros_node(name: str = "servicesim") -> Node:
    """The simulator's node, without the parameter and type-description services.

    The simulator has no ROS parameters (its settings are command-line arguments), and each
    service is one more entity in every wait set the loop builds.
    """
    return Node(name, start_parameter_services=False, parameter_overrides=[
        Parameter("start_type_description_service", value=False)])


def run_simulator(settings: SimSettings, *, engine: SimEngine | None = None) -> int:
    """Run until Ctrl-C, SIGTERM or SIGHUP; returns the process exit status.

    The first stop signal ends the loop; from then on further ones are ignored, so that the
    shut-down (which deletes the DDS participant and its shared-memory segment) is not cut
    short: a run that dies sends one SIGTERM per thread it had (``PR_SET_PDEATHSIG``).
    """
    stopped: list[int] = []

    def stop(number: int, _frame: object) -> None:
        stopped.append(number)
        for each in STOP_SIGNALS:
            signal.signal(each, signal.SIG_IGN)
        raise KeyboardInterrupt

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    executor: DrainingExecutor | None = None
    resets: EpisodeResets | None = None
    simulator: SimulatorNode | None = None
    try:
        for number in handled():  # those the process was started with ignored stay ignored
            signal.signal(number, stop)
        executor = DrainingExecutor()
        resets = EpisodeResets(episodes_ros_node())
        executor.add_node(resets.node)
        while True:
            simulator = _start_episode(settings, engine, executor, resets)
            try:
                simulator.run(executor)
                break
            except ResetRequested:
                _end_episode(simulator, executor)
                simulator = None
                episode = resets.take()
                settings, engine = episode.settings, episode.engine
    except KeyboardInterrupt:
        pass
    except RuntimeError:  # the stop raised inside a pybind11 call, which turns it into this
        if not stopped:
            raise
    finally:
        for number in STOP_SIGNALS:  # a stop that came before the handler ran: clean up anyway
            signal.signal(number, signal.SIG_IGN)
        if simulator is not None and executor is not None:
            _end_episode(simulator, executor)
        if executor is not None:
            executor.shutdown()
        if resets is not None:
            resets.node.destroy_node()
        rclpy.try_shutdown()
    return 0


def _start_episode(settings: SimSettings, engine: SimEngine | None,
                   executor: DrainingExecutor, resets: EpisodeResets) -> SimulatorNode:
    """A new simulator node for ``settings``, spun by ``executor``; a reset waiting for it
    is answered."""
    node = simulator_ros_node()
    simulator = SimulatorNode(settings, node=node, engine=engine, resets=resets)
    executor.add_node(node)
    resets.started()
    executor.note_resumable()  # the reset's coroutine resumes, and answers, in the next drain
    # what lives now (modules, the world, the maps) lives for the episode: the cyclic collector
    # stops walking it, which was 5 % of a driven period's CPU (the last episode's is collected
    # first, so a warm simulator does not keep it)
    gc.unfreeze()
    gc.collect()
    gc.freeze()
    task = simulator.engine.scenario.task
    node.get_logger().info(
        f"world {settings.world.name}: task {task.pick_up} -> {task.drop_off}, "
        f"guest {task.guest_name}, seed {settings.seed}, speed {settings.speed}")
    return simulator


def _end_episode(simulator: SimulatorNode, executor: DrainingExecutor) -> None:
    """Drop the episode's node and everything on it."""
    simulator.close(executor)
    executor.remove_node(simulator.node)
    simulator.node.destroy_node()
