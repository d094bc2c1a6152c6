"""``python -m bt_servicesim.tree_model TREE...``: regenerate a tree file's node model, or check it.

The model is generated from the code by :mod:`bt_servicesim.tree.model`; ``--check`` exits 1
when a committed model no longer matches the behaviours (CI runs it), 2 on a broken file.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence
from pathlib import Path

from bt_servicesim.cli import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, OneLineArgumentParser
from bt_servicesim.tree.model import model_for, with_model


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog="python -m bt_servicesim.tree_model",
                                   description="Regenerate or check a tree file's node model.")
    parser.add_argument("--check", action="store_true", help="exit 1 if the model is stale")
    parser.add_argument("trees", nargs="+", type=Path)
    args = parser.parse_args(argv)
    stale = []
    for tree_file in args.trees:
        try:
            text = tree_file.read_text()
            updated = with_model(text, model_for(tree_file))
        except (OSError, ElementTree.ParseError, ValueError) as error:
            print(f"{parser.prog}: error: {tree_file}: {error}", file=sys.stderr)
            return EXIT_BAD_INPUT
        if updated != text:
            stale.append(tree_file)
            if not args.check:
                tree_file.write_text(updated)
    if args.check and stale:
        print(f"stale TreeNodesModel in: {', '.join(map(str, stale))}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
