"""The simulator's settings, checked before anything starts.

Command-line arguments become a :class:`SimSettings`: the loaded world, the seed, the speed
factor, the difficulty knobs and the robot's navigation parameters (``--nav-params``). Every
problem is a :class:`SettingsError` whose message is the one line the user sees (a broken world
file or parameters file names the file and what is wrong with it).

A world can load and still be unplayable: too few target areas for a random task, no free spot
in an area, no room for its people, a fixed task whose areas navigation cannot reach from the
start. :func:`playable_engine` finds that out by building the engine (the task drawn, the
people placed, a draw idlers cut off drawn again: :mod:`servicesim_sim.model.playable`) before
ROS is touched, so it is one line and exit status 2 like any broken world file, never a
traceback from inside a running node.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from servicesim_sim.model.scenario import Difficulty, ScenarioError
from servicesim_sim.navigation.parameters import (
    SERVICEBOT,
    NavigationParameters,
    NavigationParametersError,
    load_navigation_parameters,
)
from servicesim_sim.world.files import DEFAULT_WORLD, World, WorldError, load_world

if TYPE_CHECKING:
    from servicesim_sim.model.engine import SimEngine


class SettingsError(ValueError):
    """A bad argument or world file; the message is one line."""


@dataclass(frozen=True)
class SimSettings:
    world: World
    seed: int | None
    speed: float
    difficulty: Difficulty
    camera_rate_hz: float
    await_lockstep_s: float = 0.0
    """Wall seconds to hold at the first period for a lockstep client to join."""
    navigation: NavigationParameters = SERVICEBOT
    """The robot's navigation parameters (``--nav-params FILE``; default the servicebot's)."""


_KNOBS = {
    # argument name: (Difficulty field, lowest, highest)
    "drift_scale": ("drift_scale", 0.01, 100.0),
    "nav_abort_probability": ("nav_abort_probability", 0.0, 1.0),
    "rfid_dropout": ("rfid_dropout", 0.0, 1.0),
    "service_latency": ("service_latency_s", 0.0, 60.0),
    "odom_drift": ("odom_drift", 0.0, 0.5),
    "localisation_noise": ("localisation_noise", 0.0, 1.0),
}


def settings_from_arguments(args: argparse.Namespace, *,
                            load: Callable[[str | Path], World] = load_world) -> SimSettings:
    """The checked settings; ``load`` loads the world file (an episode reset keeps the worlds
    it loaded: :class:`~servicesim_sim.ros.episodes.WorldShelf`)."""
    if args.seed is not None and args.seed < 0:
        raise SettingsError(f"--seed {args.seed}: must be 0 or more")
    if not args.speed >= 0.0:
        raise SettingsError(f"--speed {args.speed}: must be 0 or more")
    await_lockstep = getattr(args, "await_lockstep", 0.0)
    if not 0.0 <= await_lockstep <= 3600.0:
        raise SettingsError(f"--await-lockstep {await_lockstep}: must be within 0..3600")
    if not 0.0 <= args.camera_rate <= 30.0:
        raise SettingsError(f"--camera-rate {args.camera_rate}: must be within 0..30")
    try:
        world = load(args.world or DEFAULT_WORLD)
    except WorldError as error:
        raise SettingsError(str(error)) from error
    except OSError as error:
        raise SettingsError(f"{args.world}: {error.strerror or error}") from error
    return SimSettings(world=world, seed=args.seed, speed=args.speed,
                       difficulty=difficulty_from(args), camera_rate_hz=args.camera_rate,
                       await_lockstep_s=await_lockstep, navigation=navigation_from(args))


def navigation_from(args: argparse.Namespace) -> NavigationParameters:
    """The robot's navigation parameters: ``--nav-params``'s file, else the servicebot's."""
    path: str | None = args.nav_params
    if path is None:
        return SERVICEBOT
    try:
        return load_navigation_parameters(path)
    except NavigationParametersError as error:
        raise SettingsError(f"--nav-params {error}") from error


def playable_engine(settings: SimSettings) -> SimEngine:
    """The world set in motion for these settings, or a :class:`SettingsError` saying why not.

    The model is imported here, not with the module: settings that cannot be played are refused
    before the simulator loads what only playing needs (scipy among it)."""
    from servicesim_sim.model.people import CrowdError
    from servicesim_sim.model.playable import playable_engine as playable_engine_of

    try:
        return playable_engine_of(settings.world, seed=settings.seed,
                                  difficulty=settings.difficulty,
                                  navigation=settings.navigation)
    except ScenarioError as error:  # its message names the world file
        raise SettingsError(str(error)) from error
    except CrowdError as error:
        raise SettingsError(f"{settings.world.path}: {error}") from error


def difficulty_from(args: argparse.Namespace) -> Difficulty:
    difficulty = Difficulty.hard() if args.difficulty == "hard" else Difficulty.default()
    changes: dict[str, Any] = {}  # Difficulty fields of several types, from the arguments
    if args.guest_out_of_range:
        changes["guest_out_of_range"] = True
    if getattr(args, "guest_path", None):
        changes["guest_path"] = args.guest_path
    if getattr(args, "walker_routes", None):
        changes["walker_routes"] = args.walker_routes
    for argument, (field, lowest, highest) in _KNOBS.items():
        value = getattr(args, argument)
        if value is None:
            continue
        if not lowest <= value <= highest:
            flag = "--" + argument.replace("_", "-")
            raise SettingsError(f"{flag} {value}: must be within {lowest}..{highest}")
        changes[field] = value
    return dataclasses.replace(difficulty, **changes)
