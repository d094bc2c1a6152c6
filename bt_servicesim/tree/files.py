"""Where the shipped mission trees live.

Kept apart from :mod:`bt_servicesim.tree.loading`, which imports every behaviour and its
libraries: a command names its default tree in its argument parser long before it loads one.
"""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "DEFAULT_NAV_PARAMS", "DEFAULT_TREE", "SERVICEBOT", "TREES_DIRECTORY", "nav_params_for",
    "shown_path",
]

TREES_DIRECTORY = Path(__file__).resolve().parents[2] / "trees"
"""The repository's ``trees/``: the shipped mission and its node model."""
DEFAULT_TREE = TREES_DIRECTORY / "servicesim_mission.xml"
"""The mission tree a run plays unless it names another."""
DEFAULT_NAV_PARAMS = TREES_DIRECTORY / "servicesim_nav2_params.yaml"
"""The robot's navigation parameters the shipped tree plays with (a Nav2 parameters file):
the navigation belongs to the robot, as each competitor's move_base configuration did."""
SERVICEBOT = "servicebot"
"""``--nav-params servicebot``: the original servicebot's configuration, the simulator's own
default, with no file."""


def nav_params_for(executive: str, given: str | None) -> Path | None:
    """The navigation parameters file a run of ``executive`` (``bt`` or ``baseline``) gives the
    simulator: the one ``given``, none for :data:`SERVICEBOT`, and by default the shipped
    tree's (:data:`DEFAULT_NAV_PARAMS`) for ``bt`` and the servicebot's for the ``baseline``,
    which replays the original example solution on the original robot."""
    if given == SERVICEBOT:
        return None
    if given is not None:
        return Path(given).resolve()
    return DEFAULT_NAV_PARAMS if executive == "bt" else None


def shown_path(path: Path) -> str:
    """How a command or a page shows a file: relative to the repository's root when the file is
    in this checkout (a command in the docs runs from there, on any clone), else as given."""
    try:
        return str(path.resolve().relative_to(TREES_DIRECTORY.parent))
    except ValueError:
        return str(path)
