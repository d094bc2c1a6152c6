"""What the command tests share: missions run once per test process.

Two modules judge the shipped task's run (the end-to-end tests, by the referee's report and the
tree log; the localisation tests, by the pose the tree first read), so it runs once for both:
they are in one pytest-xdist group (``SHIPPED_TASK_GROUP``), which ``make test``
(``--dist loadgroup``) gives to one worker. Two end-to-end tests judge one mission of a guest
beyond RFID range (``GUEST_OUT_OF_RANGE_GROUP``), by its tree log and by its picture.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests.commands.test_end_to_end import mission


@dataclass(frozen=True)
class FinishedRun:
    out: Path
    code: int
    report: dict[str, Any]


@pytest.fixture(scope="session")
def shipped_task_run(tmp_path_factory: pytest.TempPathFactory) -> FinishedRun:
    """``python -m bt_servicesim.run`` on the shipped task, with no other argument."""
    out = tmp_path_factory.mktemp("shipped_task") / "run"
    code, report = mission(out)
    return FinishedRun(out=out, code=code, report=report)


@pytest.fixture(scope="session")
def guest_out_of_range_run(tmp_path_factory: pytest.TempPathFactory) -> FinishedRun:
    """Seed 3 with its guest beyond RFID range of the pick-up area, drawn as an evaluation asks:
    the picture only of a mission that did not complete (``--trajectory failed``)."""
    out = tmp_path_factory.mktemp("guest_out_of_range") / "run"
    code, report = mission(out, "--seed", "3", "--sim-arg=--guest-out-of-range",
                           "--trajectory", "failed")
    return FinishedRun(out=out, code=code, report=report)
