"""``run --groot``: bad addresses and a port in use are one line and exit status 2, with
nothing started and nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest

from bt_servicesim.monitor.groot2_server import Groot2Server
from bt_servicesim.run import build_parser, groot_address, settings_from
from tests.fakes.commands import run_module


def assert_refused(tmp_path: Path, *arguments: str, named: str) -> None:
    result = run_module("bt_servicesim.run", "--headless", *arguments, cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert named in lines[0]
    assert not (tmp_path / "runs").exists(), "nothing is started or written on bad input"


@pytest.mark.parametrize("argument", ["0", "65536", "port", "robot.example:1667", "::1:1667",
                                      "1.2.3:1667", ":"])
def test_a_bad_groot_address_is_one_line(tmp_path: Path, argument: str) -> None:
    assert_refused(tmp_path, f"--groot={argument}", named="--groot")


def test_the_baseline_has_no_tree_to_show(tmp_path: Path) -> None:
    assert_refused(tmp_path, "--groot", "--executive", "baseline", named="--groot")


def test_a_port_in_use_is_one_line_and_starts_no_simulator(tmp_path: Path) -> None:
    with Groot2Server(port=0) as taken:
        assert_refused(tmp_path, "--groot", str(taken.port), named=f"127.0.0.1:{taken.port}")


@pytest.mark.parametrize(("argument", "address"), [
    ("1667", ("127.0.0.1", 1667)),
    ("1700", ("127.0.0.1", 1700)),
    ("localhost:1701", ("127.0.0.1", 1701)),
    ("0.0.0.0:1667", ("0.0.0.0", 1667)),
    ("192.168.1.20:2000", ("192.168.1.20", 2000)),
])
def test_groot_binds_to_loopback_unless_an_address_is_named(
        argument: str, address: tuple[str, int]) -> None:
    assert groot_address(argument) == address


def test_groot_alone_is_loopback_on_groot2s_default_port_and_off_unless_asked() -> None:
    assert settings_from(build_parser().parse_args(["--groot"])).groot == ("127.0.0.1", 1667)
    assert settings_from(build_parser().parse_args([])).groot is None
