"""Every tutorial in docs/tutorials/ works as written.

The ```bash blocks of a tutorial are its commands; each runs, in the page's order, in a
temporary directory that stands for the repository's root (its ``trees/`` linked in), with
this interpreter's ``python`` first on the PATH. A block's info string may say what the block
promises besides: ``exit=N`` its exit status (0 unless said), ``creates=a,b`` files it leaves,
non-empty. Other blocks (```text: a viewer to open, a long run to watch) are prose.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((REPO / "docs" / "tutorials").glob("*.md"))
BLOCK = re.compile(r"^```bash([^\n]*)\n(.*?)^```$", flags=re.DOTALL | re.MULTILINE)
BLOCK_TIMEOUT_S = 600


@dataclass(frozen=True)
class Block:
    """One ```bash block: its commands and what it promises."""

    script: str
    exit_status: int
    creates: tuple[str, ...]


def blocks_in(text: str, source: str) -> list[Block]:
    """The ```bash blocks of a page's text, in order, with their ``exit=`` and ``creates=``."""
    found = []
    for info, script in BLOCK.findall(text):
        options = dict(word.split("=", 1) for word in shlex.split(info))
        unknown = set(options) - {"exit", "creates"}
        assert not unknown, f"{source}: unknown block option(s) {sorted(unknown)}"
        found.append(Block(script=script, exit_status=int(options.get("exit", "0")),
                           creates=tuple(filter(None, options.get("creates", "").split(",")))))
    return found


def blocks_of(page: Path) -> list[Block]:
    return blocks_in(page.read_text(), page.name)


def tutorial_environment() -> dict[str, str]:
    """This interpreter as ``python`` and this checkout's packages first on the import path."""
    paths = [str(REPO), str(REPO / "sim"), os.environ.get("PYTHONPATH", "")]
    return {**os.environ,
            "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
            "PYTHONPATH": os.pathsep.join(filter(None, paths))}


def test_there_are_tutorials_and_each_has_commands() -> None:
    assert len(TUTORIALS) >= 4
    for page in TUTORIALS:
        assert blocks_of(page), f"{page.name} has no ```bash block"


def test_block_options_are_read() -> None:
    text = ("```bash exit=1 creates=a.txt,b/c.json\nfalse\n```\n"
            "```bash\ntrue\n```\n```text\nnot run\n```\n")
    assert blocks_in(text, "page") == [
        Block(script="false\n", exit_status=1, creates=("a.txt", "b/c.json")),
        Block(script="true\n", exit_status=0, creates=())]


@pytest.mark.long
@pytest.mark.timeout(BLOCK_TIMEOUT_S * 4)
@pytest.mark.parametrize("page", TUTORIALS, ids=[page.stem for page in TUTORIALS])
def test_tutorial_commands_run_as_written(page: Path, tmp_path: Path) -> None:
    (tmp_path / "trees").symlink_to(REPO / "trees")
    environment = tutorial_environment()
    for number, block in enumerate(blocks_of(page), start=1):
        result = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block.script],
                                cwd=tmp_path, env=environment, capture_output=True, text=True,
                                timeout=BLOCK_TIMEOUT_S, stdin=subprocess.DEVNULL)
        where = f"{page.name}, block {number}:\n{block.script}"
        assert result.returncode == block.exit_status, (
            f"{where}exit status {result.returncode}, expected {block.exit_status}\n"
            f"stdout: {result.stdout[-2000:]}\nstderr: {result.stderr[-3000:]}")
        for name in block.creates:
            made = tmp_path / name
            assert made.is_file() and made.stat().st_size > 0, f"{where}did not leave {name}"
