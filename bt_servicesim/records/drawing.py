"""Draw a behaviour tree as ascii, unicode, dot, svg or png.

Every drawing goes through py_trees' own :mod:`py_trees.display`, with one change: a node is
labelled with its *short* name (:func:`~bt_servicesim.tree.shape.short_label`); the indentation
(text) or the edges (graphs) already show where a node sits. Text written to a file or a pipe
carries no terminal escape codes.

The dot source is deterministic for a given tree file (py_trees' ASCII symbols are pinned,
whatever the terminal's encoding: ``M`` marks memory), so a committed drawing can be checked
against its tree file. ``svg`` and ``png`` need Graphviz's ``dot`` program
(:class:`GraphvizError` when it is missing).
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any

import py_trees
import pydot

from bt_servicesim.tree.shape import ShadowTree, TreeShape, short_label, walk

TEXT_FORMATS = ("ascii", "unicode", "dot", "svg")


FORMATS = ("ascii", "unicode", "dot", "svg", "png")




class GraphvizError(RuntimeError):
    """Graphviz's ``dot`` is missing or failed; the message is one line saying what to do."""




def tree_text(root: py_trees.behaviour.Behaviour, *, symbols: str = "unicode",
              show_status: bool = True, running_only: bool = False,
              colour: bool = False) -> str:
    """A live tree drawn as text, with short names (see :meth:`ShadowTree.text`)."""
    shadow = ShadowTree(TreeShape.of(root))
    shadow.copy_from(walk(root))
    return shadow.text(symbols=symbols, show_status=show_status, running_only=running_only,
                       colour=colour)


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


PY_TREES_COMPOSITES = (py_trees.composites.Sequence, py_trees.composites.Selector,
                       py_trees.composites.Parallel)
CONTROL_COLOUR = "#f4a261"
"""Fill of a control py_trees has no symbol for, in graphs."""


def dot_source(root: py_trees.behaviour.Behaviour) -> str:
    """py_trees' dot graph of the tree, nodes labelled with short names; deterministic.

    py_trees draws a control it has no symbol for (this project's ``RecoveryNode``) as a grey
    ellipse, like a leaf; here it is a box of its own colour, labelled with its class too.
    """
    return _dot_graph(root).to_string()


HEAT_COLD, HEAT_HOT, NEVER_RAN = (255, 255, 255), (214, 39, 40), "#e0e0e0"
HEAT_FIGURES = (("ran_share", "ran in", "percent"), ("starts_per_episode", "starts/ep", "number"),
                ("failure_rate", "fails", "percent"), ("time_share", "time", "percent"),
                ("points_under", "points/ep", "number"))
"""The figures a heat map's label shows under each node's name: key, label, format."""


def heat_dot_source(root: py_trees.behaviour.Behaviour,
                    figures: Mapping[str, Mapping[str, Any]], *, measure: str,
                    title: str) -> str:
    """The tree's dot graph with each node filled by ``measure`` (white: 0, red: the largest
    value; grey: no figures, never ran) and its figures in its label.

    ``figures``: a node table's rows (:mod:`bt_servicesim.evaluation.node_tables`) by node key
    (the behaviour's name, as py_trees' dot graph names its nodes)."""
    graph = _dot_graph(root)
    values = [float(row[measure]) for row in figures.values() if row.get(measure) is not None]
    top = max(values, default=0.0)
    for node in graph.get_nodes():
        name = node.get_name().strip('"')
        row = figures.get(name)
        if row is None or node.get("label") is None:
            if node.get("label") is not None:
                node.set("fillcolor", NEVER_RAN)
            continue
        value = row.get(measure)
        node.set("fillcolor", heat_colour(0.0 if value is None or top <= 0 else value / top))
        node.set("fontcolor", "black")
        node.set("style", "filled")
        node.set("label", f'"{_heat_label(short_label(name), row)}"')
    graph.set("label", f'"{title}"')
    graph.set("labelloc", "t")
    return graph.to_string()


def heat_colour(fraction: float) -> str:
    """White to red, by ``fraction`` (clipped to 0..1)."""
    fraction = min(1.0, max(0.0, fraction))
    red, green, blue = (round(cold + (hot - cold) * fraction)
                        for cold, hot in zip(HEAT_COLD, HEAT_HOT, strict=True))
    return f"#{red:02x}{green:02x}{blue:02x}"


def _heat_label(name: str, row: Mapping[str, Any]) -> str:
    parts = [name]
    for key, label, style in HEAT_FIGURES:
        value = row.get(key)
        if value is None:
            continue
        shown = f"{value:.0%}" if style == "percent" else f"{value:.2f}"
        parts.append(f"{label} {shown}")
    return "\\n".join(parts)


def _dot_graph(root: py_trees.behaviour.Behaviour) -> pydot.Dot:
    with _ascii_symbols():
        graph = py_trees.display.dot_tree(root)
    graph.set_name(py_trees.utilities.get_valid_filename(short_label(root.name)) or "tree")
    controls = {behaviour.name: type(behaviour).__name__ for behaviour in root.iterate()
                if isinstance(behaviour, py_trees.composites.Composite)
                and not isinstance(behaviour, PY_TREES_COMPOSITES)}
    for node in graph.get_nodes():
        name, label = node.get_name().strip('"'), node.get("label")
        if label is not None and name:
            node.set("label", label.replace(name, short_label(name), 1))
        if name in controls:
            node.set("label", f'"{short_label(name)}\\n({controls[name]})"')
            node.set("shape", "box")
            node.set("fillcolor", CONTROL_COLOUR)
    return graph


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
