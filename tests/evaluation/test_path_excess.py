"""Where the time over the bound goes (:mod:`bt_servicesim.evaluation.path_excess`): the path
driven against the bound's route, the mean speed, the share of the mission standing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bt_servicesim.evaluation.path_excess import (
    Sample,
    figures_of,
    path_figures,
    summary_lines,
)
from tests.fakes.commands import run_module


def straight_drive(*, wait_s: float, drive_s: float, speed: float) -> list[Sample]:
    """10 Hz samples: standing for ``wait_s`` before the task, then driving along x."""
    samples = [Sample(t=step / 10.0, x=0.0, y=0.0, v=0.0) for step in range(int(wait_s * 10))]
    for step in range(int(drive_s * 10) + 1):
        samples.append(Sample(t=wait_s + step / 10.0, x=speed * step / 10.0, y=0.0, v=speed))
    return samples


def test_the_path_and_the_speed_are_measured_over_the_referees_task_time() -> None:
    samples = straight_drive(wait_s=3.0, drive_s=20.0, speed=0.5)  # 10 m from t = 3 s
    # the task started at 2 s (the robot set off a second later) and ended at 22 s
    figures = path_figures(samples, task_start_s=2.0, sim_time_s=20.0, bound_length_m=8.0,
                           time_over_bound=2.5)
    assert figures is not None
    assert figures.path_over_bound == pytest.approx(9.5 / 8.0), "the last second is after it"
    assert figures.mean_speed_m_s == pytest.approx(9.5 / 20.0)
    assert figures.standing_share == pytest.approx(10 / 201), "the second before setting off"
    assert figures.time_over_bound == 2.5


def test_standing_counts_the_samples_slower_than_the_threshold() -> None:
    samples = straight_drive(wait_s=0.0, drive_s=10.0, speed=0.5)
    stop = samples[-1]
    samples += [Sample(t=stop.t + step / 10.0, x=stop.x, y=0.0, v=0.0) for step in range(1, 12)]
    figures = path_figures(samples, task_start_s=0.0, sim_time_s=11.1, bound_length_m=5.0,
                           time_over_bound=2.2)
    assert figures is not None
    assert figures.standing_share == pytest.approx(11 / 112)


def test_an_unknown_task_start_or_an_empty_bound_gives_no_figures() -> None:
    moving = straight_drive(wait_s=0.0, drive_s=2.0, speed=0.5)
    assert path_figures(moving, task_start_s=None, sim_time_s=2.0, bound_length_m=3.0,
                        time_over_bound=1.0) is None
    assert path_figures(moving, task_start_s=0.0, sim_time_s=2.0, bound_length_m=0.0,
                        time_over_bound=1.0) is None


def test_only_completed_rows_with_a_bound_and_a_recording_are_measured(tmp_path: Path) -> None:
    rows = [{"completed": False, "kinematic_bound_legs": [{"length_m": 1.0}],
             "time_over_bound": None, "out": str(tmp_path), "sim_time_s": 10.0},
            {"completed": True, "kinematic_bound_legs": None, "time_over_bound": None,
             "out": str(tmp_path), "sim_time_s": 10.0},
            {"completed": True, "kinematic_bound_legs": [{"length_m": 1.0}],
             "time_over_bound": 2.0, "out": str(tmp_path / "no-run"), "sim_time_s": 10.0}]
    assert figures_of(rows) == []


def test_the_summary_gives_median_and_percentiles_of_each_figure() -> None:
    samples = straight_drive(wait_s=0.0, drive_s=20.0, speed=0.5)
    figures = [path_figures(samples, task_start_s=0.0, sim_time_s=20.0, bound_length_m=length,
                            time_over_bound=10.0 / length) for length in (5.0, 8.0, 10.0)]
    lines = summary_lines([f for f in figures if f is not None])
    assert lines[0] == "3 completed missions with a bound and a recording"
    assert lines[2].startswith("path_over_bound: median 1.250 ")


@pytest.mark.parametrize("content", [None, "not json", json.dumps({"baseline": {"rows": []}}),
                                     json.dumps({"bt": {"rows": []}})])
def test_a_bad_evaluation_directory_gets_one_line_and_exit_2(tmp_path: Path,
                                                             content: str | None) -> None:
    if content is not None:
        (tmp_path / "summary.json").write_text(content)
    done = run_module("bt_servicesim.evaluation.path_excess", str(tmp_path))
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "summary.json" in lines[0], done.stderr
