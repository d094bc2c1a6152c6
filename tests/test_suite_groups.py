"""The suite's own set-up: ``make test`` runs pytest-xdist with ``--dist loadgroup``, which
gives every test of one ``xdist_group`` to one worker, so that a run the group's tests share
(the shipped task's mission, a Dask cluster) is played once. pytest-xdist marks a grouped test
by appending its group to the test's id; a pytest that drops that suffix splits the groups
silently, so this test checks it is there whenever the suite runs under ``loadgroup``.
"""

from __future__ import annotations

import pytest

GROUP = "suite_groups"


@pytest.mark.xdist_group(GROUP)
def test_a_grouped_test_carries_its_group_under_loadgroup(request: pytest.FixtureRequest) -> None:
    if getattr(request.config.option, "loadgroup", False):  # a pytest-xdist worker, loadgroup
        assert request.node.nodeid.endswith(f"@{GROUP}"), request.node.nodeid
    else:
        assert "@" not in request.node.nodeid, request.node.nodeid
