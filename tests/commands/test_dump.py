"""``python -m bt_servicesim.dump``: every format, its errors, and the committed mission-tree image.

The committed drawing (docs/images/mission_tree.svg, with the dot source it was rendered from
beside it) must match the tree file: the dot source is compared with a fresh one, and the SVG's
nodes and edges with the dot source's.
"""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import py_trees
import pydot
import pytest
from PIL import Image

from bt_servicesim import dump
from bt_servicesim.tree.loading import DEFAULT_TREE, load_mission_tree
from bt_servicesim.tree.shape import TreeShape, walk

REPO = Path(__file__).resolve().parents[2]
DOCS_DOT = REPO / "docs" / "images" / "mission_tree.dot"
DOCS_SVG = REPO / "docs" / "images" / "mission_tree.svg"
SVG = "{http://www.w3.org/2000/svg}"
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning:pydot")  # pydot's parser

SMALL_TREE = """<root BTCPP_format="4" main_tree_to_execute="Errand">
  <BehaviorTree ID="Errand">
    <Parallel name="Errand" policy="success_on_one">
      <SimWait name="Pause" seconds="1.0"/>
      <Sequence name="Work" memory="true">
        <CopyGoal name="Copy" goal="{goal}" copy="{attempt}"/>
        <SubTree ID="Backup" name="Backup" goal="{attempt}"/>
        <Inverter name="Invert"><SimWait name="Pause" seconds="2.0"/></Inverter>
      </Sequence>
    </Parallel>
  </BehaviorTree>
  <BehaviorTree ID="Backup">
    <Fallback name="Backup" memory="false">
      <CopyGoal name="Copy" goal="{goal}" copy="{local}"/>
    </Fallback>
  </BehaviorTree>
</root>
"""
LABELS = ["Errand", "Pause", "Work", "Copy", "Backup", "Copy", "Invert", "Pause"]


@pytest.fixture
def small_tree(tmp_path: Path) -> Path:
    path = tmp_path / "errand.xml"
    path.write_text(SMALL_TREE)
    return path


def run_dump(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    try:
        code = dump.main(list(argv))
    except SystemExit as exit_:  # argparse's own errors
        code = int(exit_.code or 0)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_unicode_and_ascii_drawings_show_every_node_by_its_short_name(
        small_tree: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for output_format in ("unicode", "ascii"):
        code, out, _ = run_dump(capsys, "--tree", str(small_tree), "--format", output_format)
        assert code == 0
        lines = out.splitlines()
        assert [line.split()[-1] for line in lines] == LABELS
        assert lines[0] == "/_/ Errand" and lines[2] == "    {-} Work"
        assert lines[5] == "            --> Copy"  # inside the subtree's fallback
        assert "\x1b" not in out and "." not in out
        assert out.isascii()


def test_the_dot_drawing_has_a_node_per_behaviour_and_an_edge_per_child(
        small_tree: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_dump(capsys, "--tree", str(small_tree), "--format", "dot")
    assert code == 0
    graph = pydot.graph_from_dot_data(out)[0]
    nodes = {node.get_name().strip('"'): node.get("label").strip('"')
             for node in graph.get_nodes() if node.get("label")}
    assert sorted(nodes.values()) == sorted([r"Errand\nSuccessOnOne", "Pause", "M Work", "Copy",
                                             "Backup", "Copy", "Invert", "Pause"])
    assert len(nodes) == len(LABELS)  # repeated short names are still distinct nodes
    edges = {(edge.get_source().strip('"'), edge.get_destination().strip('"'))
             for edge in graph.get_edges()}
    assert ("Errand.Work", "Errand.Work.Copy") in edges
    assert ("Errand.Work.Invert", "Errand.Work.Invert.Pause") in edges
    assert len(edges) == len(LABELS) - 1


def test_the_dot_source_does_not_depend_on_the_terminals_encoding(
        small_tree: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = load_mission_tree(small_tree)
    expected = dump.dot_source(root)
    monkeypatch.setattr("py_trees.console.has_unicode", lambda *_args, **_kwargs: True)
    assert dump.dot_source(root) == expected
    assert '"M Work"' in expected and py_trees.console.has_unicode()


def test_svg_is_written_with_its_dot_source_beside_it(
        small_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "tree.svg"
    code, _, _ = run_dump(capsys, "--tree", str(small_tree), "--format", "svg", "--out", str(out),
                          "--with-dot")
    assert code == 0
    assert out.with_suffix(".dot").read_text() == dump.dot_source(load_mission_tree(small_tree))
    assert svg_graph(out) == dot_graph(out.with_suffix(".dot").read_text())


def test_png_is_a_real_image_of_the_tree(
        small_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "tree.png"
    code, _, _ = run_dump(capsys, "--tree", str(small_tree), "--format", "png", "--out", str(out))
    assert code == 0
    with Image.open(out) as image:
        assert image.format == "PNG"
        width, height = image.size
        colours = image.convert("RGB").getcolors(maxcolors=1_000_000)
    assert width > 200 and height > 150
    assert colours is not None and len(colours) > 20  # text and filled shapes, not a blank page


def test_without_graphviz_images_fail_with_one_line_saying_how_to_get_it(
        small_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    code, _, err = run_dump(capsys, "--tree", str(small_tree), "--format", "png",
                            "--out", str(tmp_path / "tree.png"))
    assert code == 1
    assert "Graphviz is not installed" in err and "apt-get install graphviz" in err
    assert err.count("\n") == 1
    assert not (tmp_path / "tree.png").exists()


@pytest.mark.parametrize(("argv", "problem"), [
    (["--tree", "{missing}"], "no such tree file"),
    (["--tree", "{broken}"], "not well-formed XML"),
    (["--format", "png"], "--format png needs --out FILE"),
    (["--format", "svg", "--with-dot"], "--with-dot needs --out FILE"),
    (["--out", "{tmp}/nowhere/tree.txt"], "does not exist"),
    (["--out", "{tmp}"], "is a directory"),
    (["--format", "jpeg"], "invalid choice: 'jpeg'"),
])
def test_bad_input_is_one_line_and_exit_2(
        small_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        argv: list[str], problem: str) -> None:
    broken = tmp_path / "broken.xml"
    broken.write_text("<root><BehaviorTree")
    names = {"missing": tmp_path / "missing.xml", "broken": broken, "tmp": tmp_path}
    argv = [arg.format(**names) for arg in argv]
    if "--tree" not in argv:
        argv = ["--tree", str(small_tree), *argv]
    code, out, err = run_dump(capsys, *argv)
    assert code == 2 and out == ""
    assert problem in err and err.count("\n") == 1


def test_the_command_runs_as_a_module(small_tree: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "bt_servicesim.dump", "--tree", str(small_tree)],
        capture_output=True, text=True, check=False, cwd=REPO, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[0] == "/_/ Errand"


def test_short_labels_keep_keys_unique() -> None:
    root = load_mission_tree(DEFAULT_TREE)
    shape = TreeShape.of(root)
    assert len(set(shape.keys)) == len(shape.nodes) == len(walk(root))
    assert all("." not in node.label for node in shape.nodes)


def test_the_committed_mission_tree_drawing_matches_the_tree_file() -> None:
    fresh = dump.dot_source(load_mission_tree(DEFAULT_TREE))
    assert DOCS_DOT.read_text() == fresh, (
        "docs/images/mission_tree.* is stale; regenerate it with: python -m bt_servicesim.dump "
        "--format svg --out docs/images/mission_tree.svg --with-dot")
    assert svg_graph(DOCS_SVG) == dot_graph(fresh)


def dot_graph(dot_text: str) -> tuple[set[str], set[tuple[str, str]]]:
    graph = pydot.graph_from_dot_data(dot_text)[0]
    nodes = {node.get_name().strip('"') for node in graph.get_nodes() if node.get("label")}
    edges = {(edge.get_source().strip('"'), edge.get_destination().strip('"'))
             for edge in graph.get_edges()}
    return nodes, edges


def svg_graph(path: Path) -> tuple[set[str], set[tuple[str, str]]]:
    """The node names and edges Graphviz wrote into an SVG (from each group's title)."""
    root = ElementTree.parse(path).getroot()
    nodes, edges = set(), set()
    for group in root.iter(f"{SVG}g"):
        title = group.find(f"{SVG}title")
        if group.get("class") == "node" and title is not None:
            nodes.add(title.text or "")
        elif group.get("class") == "edge" and title is not None:
            source, _, destination = (title.text or "").partition("->")
            edges.add((source, destination))
    return nodes, edges


def test_a_control_py_trees_has_no_symbol_for_is_drawn_as_itself(tmp_path: Path) -> None:
    tree = tmp_path / "recovery.xml"
    tree.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M"><BehaviorTree ID="M">'
        '<RecoveryNode name="Retrying" number_of_retries="2">'
        '<ClearCostmaps name="Act"/><ClearCostmaps name="Recover"/>'
        '</RecoveryNode></BehaviorTree></root>')
    source = dump.dot_source(load_mission_tree(tree))
    retrying = next(line for line in source.splitlines() if "label=\"Retrying" in line)
    assert "(RecoveryNode)" in retrying and "shape=box" in retrying
    act = next(line for line in source.splitlines() if "label=Act" in line)
    assert "shape=ellipse" in act  # leaves stay as py_trees draws them
