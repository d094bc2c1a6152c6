"""One section of ``results.md`` as an evaluation of no episodes writes it, for the tests of
what the report states from figures files (reproducibility, throughput)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from bt_servicesim.evaluation.report import markdown_report
from bt_servicesim.evaluation.settings import EvaluationSettings


def report_section(tmp_path: Path, *, heading: str, **figures: Any) -> str:
    """The text under ``## heading`` up to the failure table, with ``figures`` (the settings'
    loaded figures, by field name) given to the evaluation."""
    settings = EvaluationSettings(
        episodes=1, scenarios=("random",), executives=("bt",), jobs=1, seed=0,
        out=tmp_path / "evaluation", speed=0.0, episode_timeout_s=60.0, time_limit_s=900.0,
        docs=None, command_line="python -m bt_servicesim.evaluate (test)", **figures)
    report = markdown_report(settings, [], ".", revision="commit `abc`")
    return report.split(f"## {heading}")[1].split("## Why episodes failed")[0]
