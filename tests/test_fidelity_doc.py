"""docs/fidelity.md lists the simulator's rules, and every row names a test that exists.

A row whose test was renamed or deleted would claim a pin that is gone; this test fails then.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PAGE = REPO / "docs" / "fidelity.md"
NODE_ID = re.compile(r"`(tests/[\w/]+\.py)::(\w+)(?:\[[^\]]*\])?`")


def table_rows() -> list[list[str]]:
    rows = []
    for line in PAGE.read_text().splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if line.startswith("|") and len(cells) == 4 and not set(cells[0]) <= {"-"}:
            rows.append(cells)
    return rows[1:]  # the header


def functions_in(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    return {node.name for node in ast.walk(tree)
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)}


def test_the_page_has_a_row_per_rule() -> None:
    names = [row[0] for row in table_rows()]
    assert len(names) >= 20
    assert len(names) == len(set(names)), "a rule listed twice"


def test_every_row_cites_the_original_and_names_tests_that_exist() -> None:
    missing = []
    for rule, original, ours, tests in table_rows():
        assert original and ours, f"{rule}: a cell is empty"
        ids = NODE_ID.findall(tests)
        assert ids, f"{rule}: no test named"
        for file, name in ids:
            path = REPO / file
            if not path.is_file() or name not in functions_in(path):
                missing.append(f"{rule}: {file}::{name}")
    assert missing == []
