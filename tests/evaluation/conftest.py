"""Evaluation tests get their kinematic bounds from a stand-in (``bound_fakes.py``): the real
command searches the office for every task, seconds each, and is tested on its own
(``tests/sim/test_task_bound.py``); ``test_kinematic_bound.py`` tests the evaluation's use of it.
"""

from __future__ import annotations

import os

import pytest

from bt_servicesim.evaluation import kinematic_bound
from tests.evaluation.bound_fakes import fake_bound_command


@pytest.fixture(autouse=True)
def stand_in_bound_command(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(kinematic_bound, "BOUND_COMMAND", fake_bound_command(os.devnull))
