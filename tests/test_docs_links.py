"""Every relative link in the README and docs/ leads somewhere: the file exists, and a link to a
heading of a Markdown page names a heading the page has (GitHub's anchors: lower case, spaces to
hyphens, punctuation but ``-`` and ``_`` dropped). Every source file the prose names by its path
(```bt_servicesim/ros/lockstep.py```, ```servicesim_sim/...```, ```tests/...```) exists, so a
module that moves takes its mentions along."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", flags=re.DOTALL | re.MULTILINE)
TO_BE_WRITTEN = {  # files a page tells the reader to create
    "docs/architecture.md": {"bt_servicesim/behaviours/conditions/robot_near_pose.py",
                             "tests/behaviours/conditions/test_robot_near_pose.py"},
}
SOURCE_PATH = re.compile(
    r"`((?:sim/)?(?:bt_servicesim|servicesim_sim|tests|benchmarks|trees|interfaces)/[\w/.-]+"
    r"\.(?:py|xml|yaml|sh))`")


def anchor(heading: str) -> str:
    """GitHub's anchor for a heading's text."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors_of(page: Path) -> set[str]:
    text = FENCE.sub("", page.read_text())
    return {anchor(line.lstrip("#")) for line in text.splitlines() if line.startswith("#")}


def links_of(page: Path) -> list[str]:
    text = FENCE.sub("", page.read_text())
    return [target for target in LINK.findall(text)
            if not re.match(r"[a-z]+:", target)]


def test_anchors_follow_githubs_rule() -> None:
    assert anchor("The simulator (`servicesim_sim`)") == "the-simulator-servicesim_sim"
    assert anchor("### `trajectory.png`".lstrip("#")) == "trajectorypng"
    assert anchor("Walker standoffs, and how the tree gives way") == (
        "walker-standoffs-and-how-the-tree-gives-way")


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(REPO)) for p in PAGES])
def test_relative_links_resolve(page: Path) -> None:
    broken = []
    for target in links_of(page):
        path, _, fragment = target.partition("#")
        linked = (page.parent / path).resolve() if path else page
        if not linked.exists():
            broken.append(f"{target}: no such file")
        elif fragment and linked.suffix == ".md" and fragment not in anchors_of(linked):
            broken.append(f"{target}: {linked.name} has no heading '#{fragment}'")
    assert not broken, f"{page.relative_to(REPO)}: " + "; ".join(broken)


def named_paths(page: Path) -> list[str]:
    return SOURCE_PATH.findall(FENCE.sub("", page.read_text()))


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(REPO)) for p in PAGES])
def test_named_source_files_exist(page: Path) -> None:
    to_be_written = TO_BE_WRITTEN.get(str(page.relative_to(REPO)), set())
    missing = [path for path in named_paths(page) if path not in to_be_written
               and not (REPO / path).exists() and not (REPO / "sim" / path).exists()]
    assert not missing, f"{page.relative_to(REPO)} names files that do not exist: {missing}"
