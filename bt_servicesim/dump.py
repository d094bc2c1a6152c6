"""Draw a behaviour tree as ascii, unicode, dot, svg or png: ``python -m bt_servicesim.dump``.

Every drawing goes through py_trees' own :mod:`py_trees.display`, with one change: a node is
labelled with its *short* name. The XML parser qualifies names with their ancestors'
(``ServiceSimMission.MissionTimeLimit.Mission.Pickup.Pickup.GoToPickUpArea...``), which keeps
them unique but makes a drawing unreadable; the indentation (text) or the edges (graphs) already
show where a node sits.

Text drawings are made from a :class:`TreeShape` — the tree's structure as plain data (one
:class:`NodeShape` per behaviour, in display order) — rebuilt as a :class:`ShadowTree` of inert
py_trees behaviours of the same kinds. The same shape is the header of a run's snapshot log, so
a replay, the live view and ``final_tree.txt`` all draw exactly what a dump of the live tree
draws. Text written to a file or a pipe carries no terminal escape codes.

The dot source is deterministic for a given tree file (py_trees' ASCII symbols are pinned,
whatever the terminal's encoding: ``M`` marks memory), so a committed drawing can be checked
against its tree file. ``svg`` and
``png`` need Graphviz's ``dot`` program; without it the command says so in one line and exits 1.
Bad input (a missing or broken tree file, an unwritable ``--out``) is one line and exit 2.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import py_trees
from py_trees.common import Status

EXIT_OK, EXIT_NO_GRAPHVIZ, EXIT_BAD_INPUT = 0, 1, 2
TEXT_FORMATS = ("ascii", "unicode", "dot", "svg")
FORMATS = ("ascii", "unicode", "dot", "svg", "png")
_ESCAPE_CODE = re.compile(r"\x1b\[[0-9;]*m")

NodeState = tuple[Status, str]
"""A node's status and feedback message."""


class GraphvizError(RuntimeError):
    """Graphviz's ``dot`` is missing or failed; the message is one line saying what to do."""


# ----------------------------------------------------------------------------- the tree's shape
@dataclass(frozen=True)
class NodeShape:
    """One behaviour as drawn: where it sits and what kind of node it is.

    Attributes:
        key: unique within the tree: the behaviour's full name, ``~2``, ``~3``... when repeated
        label: the short name shown in drawings
        kind: ``sequence``, ``selector``, ``parallel``, ``decorator``, ``composite`` or
            ``behaviour`` (the kinds py_trees draws differently)
        memory: whether a sequence or selector has memory
        parent: index of the parent in :attr:`TreeShape.nodes`, ``None`` for the root
    """

    key: str
    label: str
    kind: str
    memory: bool
    parent: int | None


@dataclass(frozen=True)
class TreeShape:
    """A tree's structure as plain data, root first, children in order (pre-order)."""

    nodes: tuple[NodeShape, ...]

    @classmethod
    def of(cls, root: py_trees.behaviour.Behaviour) -> TreeShape:
        behaviours = walk(root)
        index = {id(behaviour): position for position, behaviour in enumerate(behaviours)}
        keys = unique_keys(behaviours)
        return cls(nodes=tuple(
            NodeShape(
                key=key, label=short_label(behaviour.name), kind=kind_of(behaviour),
                memory=bool(getattr(behaviour, "memory", False)),
                parent=None if behaviour.parent is None or behaviour is root
                else index[id(behaviour.parent)],
            )
            for behaviour, key in zip(behaviours, keys, strict=True)
        ))

    def to_json(self) -> list[dict[str, Any]]:
        return [asdict(node) for node in self.nodes]

    @classmethod
    def from_json(cls, nodes: Sequence[Mapping[str, Any]]) -> TreeShape:
        """The inverse of :meth:`to_json`; raises ``ValueError`` on a malformed list."""
        try:
            shapes = tuple(
                NodeShape(key=str(node["key"]), label=str(node["label"]), kind=str(node["kind"]),
                          memory=bool(node["memory"]),
                          parent=None if node["parent"] is None else int(node["parent"]))
                for node in nodes
            )
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(f"malformed tree shape ({error})") from error
        if not shapes or shapes[0].parent is not None or any(
            node.parent is None or not 0 <= node.parent < position
            for position, node in enumerate(shapes[1:], start=1)
        ):
            raise ValueError("malformed tree shape (parents must come before their children)")
        return cls(nodes=shapes)

    @property
    def keys(self) -> list[str]:
        return [node.key for node in self.nodes]


def walk(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    """Every behaviour under ``root``, root first, children in order."""
    behaviours = [root]
    for child in root.children:
        behaviours.extend(walk(child))
    return behaviours


def unique_keys(behaviours: Sequence[py_trees.behaviour.Behaviour]) -> list[str]:
    seen: dict[str, int] = {}
    keys = []
    for behaviour in behaviours:
        seen[behaviour.name] = seen.get(behaviour.name, 0) + 1
        count = seen[behaviour.name]
        keys.append(behaviour.name if count == 1 else f"{behaviour.name}~{count}")
    return keys


def short_label(name: str) -> str:
    """``A.B.Leaf`` is drawn as ``Leaf`` (the XML parser's qualification dropped)."""
    return name.rsplit(".", 1)[-1].replace("\n", " ")


def kind_of(behaviour: py_trees.behaviour.Behaviour) -> str:
    if isinstance(behaviour, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(behaviour, py_trees.decorators.Decorator):
        return "decorator"
    if isinstance(behaviour, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(behaviour, py_trees.composites.Selector):
        return "selector"
    if isinstance(behaviour, py_trees.composites.Composite):
        return "composite"
    return "behaviour"


# ---------------------------------------------------------------------------- the shadow tree
class _InertLeaf(py_trees.behaviour.Behaviour):
    """A leaf that is only ever drawn, never ticked."""

    def update(self) -> Status:
        return self.status


class _InertComposite(py_trees.composites.Composite):
    """A composite of a kind py_trees has no symbol for (drawn like a leaf, as py_trees does)."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        yield self


class ShadowTree:
    """Inert py_trees behaviours in a tree's shape, holding statuses copied from elsewhere."""

    def __init__(self, shape: TreeShape) -> None:
        self.shape = shape
        self.behaviours: list[py_trees.behaviour.Behaviour] = []
        children: dict[int, list[py_trees.behaviour.Behaviour]] = {}
        for position in reversed(range(len(shape.nodes))):  # children before their parents
            node = shape.nodes[position]
            behaviour = _shadow_behaviour(node, children.pop(position, []))
            self.behaviours.append(behaviour)
            if node.parent is not None:
                children.setdefault(node.parent, []).insert(0, behaviour)
        self.behaviours.reverse()
        self.root = self.behaviours[0]
        self._index = {key: position for position, key in enumerate(shape.keys)}

    def show(self, states: Mapping[str, NodeState], *, tip: str | None = None) -> None:
        """Give every node its logged status and feedback (INVALID when absent)."""
        for key, behaviour in zip(self.shape.keys, self.behaviours, strict=True):
            behaviour.status, behaviour.feedback_message = states.get(key, (Status.INVALID, ""))
        self._point_at(tip)

    def copy_from(self, live: Sequence[py_trees.behaviour.Behaviour]) -> None:
        """Copy statuses and feedback from the live behaviours (in :func:`walk` order)."""
        for shadow, behaviour in zip(self.behaviours, live, strict=True):
            shadow.status, shadow.feedback_message = behaviour.status, behaviour.feedback_message
        tip = live[0].tip()
        self._point_at(None if tip is None else self.shape.keys[_position(live, tip)])

    def _point_at(self, tip: str | None) -> None:
        """Make the composites on the way to ``tip`` point at it, so py_trees marks it."""
        for behaviour in self.behaviours:
            if isinstance(behaviour, py_trees.composites.Composite):
                behaviour.current_child = None
        position = self._index.get(tip) if tip is not None else None
        while position is not None:
            parent = self.shape.nodes[position].parent
            if parent is not None:
                composite = self.behaviours[parent]
                if isinstance(composite, py_trees.composites.Composite):
                    composite.current_child = self.behaviours[position]
            position = parent

    def text(self, *, symbols: str = "unicode", show_status: bool = True,
             running_only: bool = False, colour: bool = False) -> str:
        """Draw the tree with py_trees' ascii or unicode art.

        Args:
            symbols: ``"unicode"`` or ``"ascii"``
            show_status: every node's status and feedback message, not just its name
            running_only: expand only RUNNING branches (the rest end in ``...``)
            colour: keep the terminal's escape codes (bold tip, coloured statuses)
        """
        draw = py_trees.display.ascii_tree if symbols == "ascii" else py_trees.display.unicode_tree
        expanded = {
            behaviour.id: behaviour.status for behaviour in self.behaviours
            if behaviour is self.root or behaviour.status == Status.RUNNING
        }
        drawing = draw(self.root, show_only_visited=running_only, show_status=show_status,
                       visited=expanded if running_only else None)
        return drawing if colour else plain(drawing)


def _shadow_behaviour(node: NodeShape,
                      children: list[py_trees.behaviour.Behaviour]) -> py_trees.behaviour.Behaviour:
    name = node.label
    if node.kind == "sequence":
        return py_trees.composites.Sequence(name=name, memory=node.memory, children=children)
    if node.kind == "selector":
        return py_trees.composites.Selector(name=name, memory=node.memory, children=children)
    if node.kind == "parallel":
        return py_trees.composites.Parallel(
            name=name, policy=py_trees.common.ParallelPolicy.SuccessOnAll(), children=children)
    if node.kind == "decorator" and len(children) == 1:
        return py_trees.decorators.PassThrough(name=name, child=children[0])
    if children:
        return _InertComposite(name=name, children=children)
    return _InertLeaf(name=name)


def _position(behaviours: Sequence[py_trees.behaviour.Behaviour],
              wanted: py_trees.behaviour.Behaviour) -> int:
    return next(index for index, behaviour in enumerate(behaviours) if behaviour is wanted)


def plain(text: str) -> str:
    """``text`` without terminal escape codes."""
    return _ESCAPE_CODE.sub("", text)


def tree_text(root: py_trees.behaviour.Behaviour, *, symbols: str = "unicode",
              show_status: bool = True, running_only: bool = False,
              colour: bool = False) -> str:
    """A live tree drawn as text, with short names (see :meth:`ShadowTree.text`)."""
    shadow = ShadowTree(TreeShape.of(root))
    shadow.copy_from(walk(root))
    return shadow.text(symbols=symbols, show_status=show_status, running_only=running_only,
                       colour=colour)


# -------------------------------------------------------------------------------- graphviz
@contextmanager
def _ascii_symbols() -> Iterator[None]:
    """py_trees picks dot's symbols from stdout's encoding at import; pin its ASCII ones.

    The unicode memory symbol (a circled M) is missing from the fonts Graphviz finds on many
    machines and renders as a box; ``M`` renders everywhere and keeps the source deterministic.
    """
    original = py_trees.console.has_unicode
    py_trees.console.has_unicode = lambda *_args, **_kwargs: False
    try:
        yield
    finally:
        py_trees.console.has_unicode = original


def dot_source(root: py_trees.behaviour.Behaviour) -> str:
    """py_trees' dot graph of the tree, nodes labelled with short names; deterministic."""
    with _ascii_symbols():
        graph = py_trees.display.dot_tree(root)
    graph.set_name(py_trees.utilities.get_valid_filename(short_label(root.name)) or "tree")
    for node in graph.get_nodes():
        name, label = node.get_name().strip('"'), node.get("label")
        if label is not None and name:
            node.set("label", label.replace(name, short_label(name), 1))
    return graph.to_string()


def render_graph(dot_text: str, *, image_format: str) -> bytes:
    """Run Graphviz's ``dot`` on ``dot_text``; ``image_format`` is ``svg`` or ``png``."""
    program = shutil.which("dot")
    if program is None:
        raise GraphvizError(
            f"Graphviz is not installed: --format {image_format} needs its 'dot' program "
            "(Debian/Ubuntu: apt-get install graphviz; or run make setup)")
    result = subprocess.run([program, f"-T{image_format}"], input=dot_text.encode(),
                            capture_output=True, check=False)
    if result.returncode != 0:
        message = " ".join(result.stderr.decode(errors="replace").split())
        raise GraphvizError(f"Graphviz failed ({message or result.returncode})")
    return result.stdout


def drawing(root: py_trees.behaviour.Behaviour, *, output_format: str) -> bytes:
    """The whole drawing in ``output_format`` (one of :data:`FORMATS`)."""
    if output_format in ("ascii", "unicode"):
        return tree_text(root, symbols=output_format, show_status=False).encode()
    source = dot_source(root)
    if output_format == "dot":
        return source.encode()
    return render_graph(source, image_format=output_format)


# ------------------------------------------------------------------------------------ command

def build_parser() -> argparse.ArgumentParser:
    from bt_servicesim.mission_tree import DEFAULT_TREE
    from bt_servicesim.run import OneLineArgumentParser

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
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    prog = "python -m bt_servicesim.dump"
    try:
        _check_output(args)
        from bt_servicesim.mission_tree import load_mission_tree

        root = load_mission_tree(args.tree)
        data = drawing(root, output_format=args.output_format)
    except GraphvizError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return EXIT_NO_GRAPHVIZ
    except ValueError as error:  # MissionTreeError and bad arguments
        print(f"{prog}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return _write(prog, args, root, data)


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
    sys.exit(main())
