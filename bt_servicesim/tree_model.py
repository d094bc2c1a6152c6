"""``python -m bt_servicesim.tree_model [--check] [--out FILE] [TREE...]``: the Groot2 node model.

Writes the node model that Groot2 imports to open the trees (:mod:`bt_servicesim.tree.model`):
every node this project registers and every other tag the trees use, generated from the code,
into ``--out`` (default ``trees/servicesim_nodes.xml``). The trees are the ``TREE`` files, by
default every tree file in ``trees/``. ``--check`` writes nothing: it exits 1 when the file is
missing or no longer matches the code (the tests run it), 2 on bad input (a tree file that cannot
be read, a tag that is no node), with one line on stderr.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from bt_servicesim.cli import EXIT_FAILED, EXIT_OK, OneLineArgumentParser, error_line, interruptible
from bt_servicesim.tree.model import DEFAULT_NODES, default_trees, nodes_file

PROG = "python -m bt_servicesim.tree_model"


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog=PROG,
                                   description="Write or check the node model Groot2 imports.")
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 if the node model file is stale")
    parser.add_argument("--out", type=Path, default=DEFAULT_NODES, metavar="FILE",
                        help=f"node model file (default: {DEFAULT_NODES.name} beside the trees)")
    parser.add_argument("trees", nargs="*", type=Path, metavar="TREE",
                        help="tree files whose tags to declare (default: every one in trees/)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    trees = args.trees or default_trees(args.out)
    try:
        text = nodes_file(trees)
    except ValueError as error:  # a tree file that cannot be read, a tag that is no node
        return error_line(PROG, error)
    try:
        current = args.out.read_text() if args.out.is_file() else None
    except OSError as error:
        return error_line(PROG, f"--out {args.out}: {error.strerror or error}")
    if args.check:
        if current != text:
            again = PROG if args.out == DEFAULT_NODES else f"{PROG} --out {args.out}"
            print(f"{PROG}: stale node model: {args.out} does not match the code; "
                  f"regenerate it with: {again}", file=sys.stderr)
            return EXIT_FAILED
        return EXIT_OK
    if current != text:
        try:
            args.out.write_text(text)
        except OSError as error:
            return error_line(PROG, f"--out {args.out}: {error.strerror or error}")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(interruptible(PROG, main))
