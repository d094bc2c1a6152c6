"""``python -m bt_servicesim.dump``: draw a tree file as ascii, unicode, dot, svg or png.

The drawing is :mod:`bt_servicesim.records.drawing`'s (py_trees' own, nodes labelled with their
short names); this module is the command around it. ``svg`` and ``png`` need Graphviz's ``dot``
program; without it the command says so in one line and exits 1. Bad input (a missing or broken
tree file, an unwritable ``--out``, an ``--out`` whose suffix names another format) is one line
and exit 2.

``--heat EVALUATION_DIR`` draws a heat map of the tree instead: each node filled by a measure of
the evaluation's node table (``--measure``, :data:`~bt_servicesim.evaluation.node_tables.MEASURES`;
``points_under`` by default) for one executive and set (``--executive``, ``--scenario``; the
first in the table by default), its figures in its label::

    python -m bt_servicesim.dump --heat runs/eval --measure time_share --format svg --out heat.svg
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import py_trees

from bt_servicesim.cli import interruptible
from bt_servicesim.records.drawing import (
    FORMATS,
    TEXT_FORMATS,
    GraphvizError,
    dot_source,
    drawing,
    heat_dot_source,
    render_graph,
)

EXIT_OK, EXIT_NO_GRAPHVIZ, EXIT_BAD_INPUT = 0, 1, 2





# ----------------------------------------------------------------------------- the tree's shape












# ---------------------------------------------------------------------------- the shadow tree














# -------------------------------------------------------------------------------- graphviz








# ------------------------------------------------------------------------------------ command

def build_parser() -> argparse.ArgumentParser:
    from bt_servicesim.cli import OneLineArgumentParser
    from bt_servicesim.tree.files import DEFAULT_TREE

    parser = OneLineArgumentParser(prog="python -m bt_servicesim.dump",
                            description="Draw a mission tree file.")
    parser.add_argument("--tree", type=Path, default=DEFAULT_TREE,
                        help="tree file (default: the ServiceSim mission)")
    parser.add_argument("--format", choices=FORMATS, default="unicode", dest="output_format",
                        help="drawing format (default unicode)")
    parser.add_argument("--out", type=Path,
                        help="output file (default: stdout, for text formats)")
    parser.add_argument("--with-dot", action="store_true",
                        help="with svg/png, also write the dot source beside the image (.dot)")
    parser.add_argument("--heat", type=Path, metavar="EVALUATION_DIR",
                        help="colour each node by a measure of this evaluation's node table "
                             "(dot, svg or png)")
    parser.add_argument("--measure", default="points_under",
                        help="with --heat: time_share, tip_share, failure_rate, points_tip, "
                             "points_under (default), starts_per_episode or ran_share")
    parser.add_argument("--executive", help="with --heat: whose figures (default: bt if "
                                            "played, else the first); give its tree with --tree")
    parser.add_argument("--scenario", help="with --heat: which set (default: the first)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    prog = "python -m bt_servicesim.dump"
    try:
        _check_output(args)
        from bt_servicesim.tree.loading import load_mission_tree

        root = load_mission_tree(args.tree)
        if args.heat is not None:
            data = heat_drawing(root, args)
        else:
            data = drawing(root, output_format=args.output_format)
    except GraphvizError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return EXIT_NO_GRAPHVIZ
    except ValueError as error:  # MissionTreeError and bad arguments
        print(f"{prog}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return _write(prog, args, root, data)


def heat_drawing(root: py_trees.behaviour.Behaviour, args: argparse.Namespace) -> bytes:
    """The heat map of ``args.heat``'s node table on ``root``, in ``args.output_format``."""
    from bt_servicesim.evaluation.node_tables import MEASURES, read_node_table

    if args.measure not in MEASURES:
        raise ValueError(f"--measure {args.measure}: choose from {', '.join(MEASURES)}")
    if args.output_format not in ("dot", "svg", "png"):
        raise ValueError(f"--heat draws a graph: --format dot, svg or png, not "
                         f"{args.output_format}")
    table = read_node_table(args.heat)
    executives = list(dict.fromkeys(row["executive"] for row in table))
    executive = args.executive or ("bt" if "bt" in executives else next(iter(executives), None))
    if executive not in executives:
        raise ValueError(f"--executive {executive}: not in {args.heat}'s node table (it has "
                         f"{', '.join(executives) or 'no executive'})")
    rows = [row for row in table if row["executive"] == executive]
    scenarios = list(dict.fromkeys(row["scenario"] for row in rows))
    scenario = args.scenario or scenarios[0]
    if scenario not in scenarios:
        raise ValueError(f"--scenario {scenario}: {executive} played {', '.join(scenarios)}")
    figures = {row["node"]: row for row in rows if row["scenario"] == scenario}
    episodes = next(iter(figures.values()))["episodes"]
    title = f"{executive}, {scenario} set, {episodes} episodes: colour = {args.measure}"
    source = heat_dot_source(root, figures, measure=args.measure, title=title)
    if args.output_format == "dot":
        return source.encode()
    return render_graph(source, image_format=args.output_format)


def _check_output(args: argparse.Namespace) -> None:
    if args.out is None:
        if args.output_format not in TEXT_FORMATS:
            raise ValueError(f"--format {args.output_format} needs --out FILE")
        if args.with_dot:
            raise ValueError("--with-dot needs --out FILE")
        return
    if args.out.is_dir():
        raise ValueError(f"--out {args.out}: is a directory; give a file name")
    if not args.out.parent.is_dir():
        raise ValueError(f"--out {args.out}: directory {args.out.parent} does not exist")
    suffix = args.out.suffix.lower().lstrip(".")
    if suffix in FORMATS and suffix != args.output_format:
        raise ValueError(f"--out {args.out}: a .{suffix} name for --format "
                         f"{args.output_format}; name the file .{args.output_format} or pass "
                         f"--format {suffix}")


def _write(prog: str, args: argparse.Namespace, root: py_trees.behaviour.Behaviour,
           data: bytes) -> int:
    if args.out is None:
        sys.stdout.write(data.decode())
        return EXIT_OK
    try:
        args.out.write_bytes(data)
        if args.with_dot and args.output_format in ("svg", "png"):
            args.out.with_suffix(".dot").write_text(dot_source(root))
    except OSError as error:
        print(f"{prog}: error: --out {args.out}: {error.strerror or error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible("python -m bt_servicesim.dump", main))
