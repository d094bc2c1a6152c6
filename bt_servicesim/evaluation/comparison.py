"""Two evaluations of the same seeds against each other: what changed between them.

One evaluation plays several executives on the same seeds, and its results.md pairs them. What
one evaluation cannot hold is compared across two: the robot's navigation parameters are every
episode's (``--nav-params``), and a change to the code or to the shipped tree is a new
checkout. ``python -m bt_servicesim.evaluation.comparison BEFORE AFTER`` takes one executive's
rows (``--executive``, default ``bt``) from each evaluation's ``summary.json``, pairs them by
set and seed, whatever each evaluation's ``--seed`` was, and prints results.md's paired table
for them (completions with McNemar's test, scores and times to the drop-off with the sign test),
preceded by what each evaluation played with: its navigation parameters and the commits its
episodes ran on. Missions only one of the two played are left out and counted.

Pure reading: nothing is played, and both directories are left as they were.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bt_servicesim.cli import EXIT_OK, OneLineArgumentParser, interruptible
from bt_servicesim.evaluation.report import paired_table
from bt_servicesim.evaluation.summary import SummaryFileError, summary_rows

PROG = "python -m bt_servicesim.evaluation.comparison"
LABELS = ("before", "after")
"""How the two evaluations are named in the table."""
def paired_rows(before: list[dict[str, Any]], after: list[dict[str, Any]]
                ) -> tuple[list[dict[str, Any]], list[str], int]:
    """Both evaluations' rows of the missions both played (same set, same seed), named
    ``before`` and ``after`` and numbered by seed; the sets, in ``before``'s order; and how
    many missions only one of them played."""
    keyed = [{(row["scenario"], row.get("episode_seed")): row for row in rows}
             for rows in (before, after)]
    both = [key for key in keyed[0] if key in keyed[1]]
    only_one = len(set(keyed[0]) ^ set(keyed[1]))
    rows = [dict(keyed[side][key], executive=LABELS[side], episode=key[1])
            for key in both for side in (0, 1)]
    scenarios = list(dict.fromkeys(scenario for scenario, _ in both))
    return rows, scenarios, only_one


def comparison_lines(before_dir: Path, after_dir: Path, executive: str = "bt") -> list[str]:
    """The comparison as markdown lines; :class:`SummaryFileError` if there is none to make."""
    (before, before_entry), (after, after_entry) = (
        summary_rows(directory, executive) for directory in (before_dir, after_dir))
    rows, scenarios, only_one = paired_rows(before, after)
    if not rows:
        raise SummaryFileError(f"{before_dir} and {after_dir} have no mission in common: "
                              f"no {executive} episode of the same set and seed in both")
    lines = [f"# {executive}: {before_dir} (before) against {after_dir} (after)", ""]
    for label, directory, played_rows, entry in zip(
            LABELS, (before_dir, after_dir), (before, after), (before_entry, after_entry),
            strict=True):
        lines.append(f"- {label}: `{directory}`, {_played_with(played_rows, entry)}")
    skipped = f"; {only_one} missions only one of them played are left out" if only_one else ""
    lines += ["", f"Paired over {len(rows) // 2} missions (same set, same seed){skipped}.", "",
              *paired_table(scenarios, rows, first="before", second="after")]
    return lines


def _played_with(rows: list[dict[str, Any]], entry: dict[str, Any]) -> str:
    """What an evaluation's episodes played with: navigation parameters and commits."""
    nav_params = entry.get("nav_params") or {}
    navigation = (f"navigation `{nav_params['file']}` (SHA-256 {str(nav_params['sha256'])[:16]})"
                  if nav_params.get("file") else "the servicebot's navigation")
    revisions = sorted({str(row.get("revision") or "an unknown commit") for row in rows})
    return f"{navigation}, episodes on {'; '.join(revisions)}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog=PROG, description=(
        "Pair two evaluations' episodes of one executive by set and seed, and print the paired "
        "table (completions, scores, times to the drop-off, each with its p-value)."))
    parser.add_argument("before", type=Path, help="an evaluation's --out directory")
    parser.add_argument("after", type=Path, help="another evaluation's --out directory")
    parser.add_argument("--executive", default="bt",
                        help="whose episodes, as both summaries name them (default bt)")
    args = parser.parse_args(argv)
    try:
        lines = comparison_lines(args.before, args.after, args.executive)
    except SummaryFileError as error:
        parser.error(str(error))
    print("\n".join(lines))
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
