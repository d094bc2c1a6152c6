"""Episode resets: a running simulator starts a new episode on request, as a cold start would.

An extension beside the competition's interfaces (docs/reference/simulator.md, "Episode reset"), for
tools that play many episodes in a row (the evaluation's warm episodes): starting a simulator
costs an interpreter, its imports and DDS discovery, seconds that a short mission does not.
``/servicesim/reset`` (``servicesim_competition/srv/ResetEpisode``) carries the simulator's
own command-line arguments (``--world``, ``--seed``, the difficulty knobs, ``--speed``,
``--await-lockstep``). They are checked exactly as the command checks them, and the world is
loaded and set in motion (task drawn, people placed) before anything changes: a request the
command would refuse gets ``accepted: false`` and the command's one-line error, and the
simulator plays on with the episode it had.

An accepted reset is applied by the simulator's loop at the end of the period under way: it
drops the whole simulator node (its publishers with their latched messages, its services and
navigation action, its lockstep counts) and builds a new one from the new settings and engine,
just as a start does, clock back to 0. The reset's answer goes out only then, so whoever asked
never hears the episode before. The service itself lives on a node of its own that outlives
the episodes (:class:`EpisodeResets`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future
from servicesim_competition.srv import ResetEpisode

from servicesim_sim.arguments import ArgumentRefused, parse_reset_arguments
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.settings import (
    SettingsError,
    SimSettings,
    playable_engine,
    settings_from_arguments,
)
from servicesim_sim.world.files import World, load_world

__all__ = ["RESET_SERVICE", "EpisodeResets", "NextEpisode", "ResetRequested",
           "next_episode"]

RESET_SERVICE = "/servicesim/reset"


class ResetRequested(Exception):  # noqa: N818 -- a signal to the loop, not an error
    """Raised inside the simulator's loop once an accepted reset waits to be applied."""


@dataclass(frozen=True)
class NextEpisode:
    """What a reset starts: settings and the engine already set in motion for them."""

    settings: SimSettings
    engine: SimEngine


class WorldShelf:
    """The worlds resets loaded, kept while their files stay as they were.

    Loading the office takes about 0.4 s of a reset's 1.5 s. A :class:`World` is never changed
    once loaded (frozen, its occupancy grid read-only), so one kept here is what loading the
    file again would give; a world file whose size or modification time changed is loaded
    again (the map files it names are not looked at: edit the world file too).
    """

    def __init__(self) -> None:
        self._worlds: dict[Path, tuple[tuple[int, int], World]] = {}

    def load(self, path: str | Path) -> World:
        resolved = Path(path).resolve()
        try:
            stat = resolved.stat()
        except OSError:
            return load_world(path)  # which says what is wrong, as a start would
        stamp = (stat.st_mtime_ns, stat.st_size)
        kept = self._worlds.get(resolved)
        if kept is not None and kept[0] == stamp:
            return kept[1]
        world = load_world(path)
        self._worlds[resolved] = (stamp, world)
        return world


def next_episode(arguments: Sequence[str], *, worlds: WorldShelf | None = None) -> NextEpisode:
    """The episode these command-line arguments start, or :class:`SettingsError` saying why
    they cannot (the message is the command's own line, without its program name)."""
    try:
        args = parse_reset_arguments(arguments)
    except ArgumentRefused as error:
        raise SettingsError(str(error)) from error
    settings = settings_from_arguments(args, load=load_world if worlds is None else worlds.load)
    return NextEpisode(settings=settings, engine=playable_engine(settings))


class EpisodeResets:
    """The reset service on a node of its own; the episode an accepted reset waits to start."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.pending: NextEpisode | None = None
        self.used = False
        """Whether a reset was ever accepted: the simulator then plays episodes one after
        another, and holds still between them (``SimulatorNode._idle``)."""
        self.worlds = WorldShelf()
        self._answered: Future[bool] | None = None
        node.create_service(ResetEpisode, RESET_SERVICE, self._reset,
                            callback_group=ReentrantCallbackGroup())

    def check(self) -> None:
        """Raise :class:`ResetRequested` if an accepted reset waits to be applied."""
        if self.pending is not None:
            raise ResetRequested

    def take(self) -> NextEpisode:
        """The episode to start now; the loop has dropped the one before."""
        if self.pending is None:
            raise RuntimeError("no reset is pending")
        episode, self.pending = self.pending, None
        return episode

    def started(self) -> None:
        """The new episode's node is up: the reset may answer."""
        if self._answered is not None:
            self._answered.set_result(True)
            self._answered = None

    async def _reset(self, request: ResetEpisode.Request,
                     response: ResetEpisode.Response) -> ResetEpisode.Response:
        if self.pending is not None or self._answered is not None:
            response.error = "a reset is already under way; ask again once it has answered"
            return response
        try:
            episode = next_episode(list(request.arguments), worlds=self.worlds)
        except SettingsError as error:
            response.error = " ".join(str(error).split())
            self.node.get_logger().warning(f"reset refused: {response.error}")
            return response
        self._answered = Future()
        self.pending, self.used = episode, True
        await self._answered
        response.accepted = True
        return response


def episodes_ros_node(name: str = "servicesim_episodes") -> Node:
    """The node of the reset service, without parameter and type-description services."""
    return Node(name, start_parameter_services=False, parameter_overrides=[
        Parameter("start_type_description_service", value=False)])
