"""The episodes an analysis command reads: one executive's, of one scenario set, of an
evaluation's ``--out`` directory.

The commands that read an evaluation's records afterwards
(:mod:`~bt_servicesim.evaluation.path_excess`, :mod:`~bt_servicesim.evaluation.passages`) take
the same three arguments and refuse a bad ``summary.json`` the same way: :func:`episode_set_parser`
makes their parser, :func:`rows_of_set` reads the rows.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from bt_servicesim.cli import OneLineArgumentParser
from bt_servicesim.evaluation.summary import SummaryFileError, summary_rows

__all__ = ["episode_set_parser", "rows_of_set"]


def episode_set_parser(*, prog: str, description: str) -> OneLineArgumentParser:
    """A parser with an evaluation's directory, ``--executive`` (default bt) and ``--set``
    (default random)."""
    parser = OneLineArgumentParser(prog=prog, description=description)
    parser.add_argument("directory", type=Path, help="an evaluation's --out directory")
    parser.add_argument("--executive", default="bt", help="whose episodes (default bt)")
    parser.add_argument("--set", dest="scenario", default="random",
                        help="which scenario set (default random)")
    return parser


def rows_of_set(parser: argparse.ArgumentParser,
                args: argparse.Namespace) -> list[dict[str, Any]]:
    """The rows of ``args.executive``'s episodes of ``args.scenario`` in ``args.directory``'s
    ``summary.json``; a summary that cannot be read is the parser's one-line error."""
    try:
        rows, _ = summary_rows(args.directory, args.executive)
    except SummaryFileError as error:
        parser.error(str(error))
    return [row for row in rows if row.get("scenario") == args.scenario]
