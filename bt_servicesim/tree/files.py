"""Where the shipped mission trees live.

Kept apart from :mod:`bt_servicesim.tree.loading`, which imports every behaviour and its
libraries: a command names its default tree in its argument parser long before it loads one.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["DEFAULT_TREE", "TREES_DIRECTORY"]

TREES_DIRECTORY = Path(__file__).resolve().parents[2] / "trees"
"""The repository's ``trees/``: the shipped mission and its node model."""
DEFAULT_TREE = TREES_DIRECTORY / "servicesim_mission.xml"
"""The mission tree a run plays unless it names another."""
