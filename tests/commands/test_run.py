"""Bad input to ``python -m bt_servicesim.run`` is one line on stderr and exit status 2."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.fakes.commands import run_module


def run(*arguments: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return run_module("bt_servicesim.run", "--headless", *arguments, cwd=cwd)


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        (["--world", "no/such/world.yaml"], "no/such/world.yaml"),
        (["--seed", "-3"], "--seed"),
        (["--seed", "seven"], "--seed"),
        (["--speed", "-1"], "--speed"),
        (["--time-limit", "0"], "--time-limit"),
        (["--tree", "no_such_tree.xml"], "no_such_tree.xml"),
        (["--tree", "."], ".: is a directory, not a tree file"),
        (["--world", "."], "--world .: is a directory, not a world file"),
        (["--out", "/proc/x/run"], "--out /proc/x/run: cannot make the run directory there"),
        (["--out", "/dev/null/run"], "--out /dev/null/run: /dev/null is not a directory"),
        (["--executive", "magic"], "--executive"),
        (["--trajectory", "sometimes"], "--trajectory"),
        (["--frobnicate"], "--frobnicate"),
    ],
)
def test_bad_arguments_get_one_line_and_exit_2(tmp_path: Path, arguments: list[str],
                                               named: str) -> None:
    result = run(*arguments, cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert named in lines[0]
    assert not (tmp_path / "runs").exists(), "nothing is started or written on bad input"


WAIT = "<BehaviorTree ID='W'><SimWait name='W' seconds='1'/></BehaviorTree>"


def tree(body: str, others: str = "") -> str:
    """A tree file whose main tree is ``body``, with the trees ``others`` beside it."""
    return (f"<root main_tree_to_execute='M'><BehaviorTree ID='M'>{body}</BehaviorTree>"
            f"{others}</root>")


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        ("<root><BehaviorTree ID='M'>", "not well-formed"),
        ("<tree/>", "expected <root>"),
        ("<root main_tree_to_execute='M'/>", "no <BehaviorTree>"),
        ("<root main_tree_to_execute='M'><BehaviorTree ID='M'><Teleport name='T'/>"
         "</BehaviorTree></root>", "Teleport"),
        ("<root main_tree_to_execute='Other'><BehaviorTree ID='M'><Sequence name='S'/>"
         "</BehaviorTree></root>", "Other"),
        ("<root main_tree_to_execute='M'><BehaviorTree ID='M'><Timeout name='T' duration='5'>"
         "<SimWait name='W' seconds='1'/></Timeout></BehaviorTree></root>", "use SimTimeout"),
        ("<root main_tree_to_execute='M'><BehaviorTree ID='M'><SubTree ID='W'/></BehaviorTree>"
         "<BehaviorTree ID='W'><SimWait name='W' seconds='1'/></BehaviorTree></root>",
         "a SubTree needs a name"),
        (tree("<SimWait name='W' seconds='nan'/>"), 'seconds="nan" is not a finite number'),
        (tree("<Retry name='R' num_failures='-3'><SimWait name='W' seconds='1'/></Retry>"),
         'num_failures="-3" is negative'),
        (tree("<RobotInArea name='A' margin='nan' box='{b}' robot_pose='{p}'/>"),
         'margin="nan" is not a finite number'),
        (tree("<GuestApproachGoal name='G' sighting_gap='-1' guest_name='{g}' "
              "rfid_history='{h}' occupancy='{o}' robot_pose='{p}' goal='{x}'/>"),
         'sighting_gap="-1" is negative'),
        (tree("<SubTree ID='W' name='S'/>", WAIT + WAIT), 'two <BehaviorTree ID="W">'),
        (tree("<SimWait name='W' seconds='1'><SimWait name='X' seconds='1'/></SimWait>"),
         "a leaf takes no child elements; it has <SimWait>"),
        ("<root main_tree_to_execute='A'><BehaviorTree ID='A'><SubTree ID='B' name='b'/>"
         "</BehaviorTree><BehaviorTree ID='B'><SubTree ID='A' name='a'/></BehaviorTree></root>",
         "a SubTree cycle: A -> B -> A"),
        ("<root><BehaviorTree ID='M'><SubTree ID='W' name='S'/></BehaviorTree>" + WAIT
         + "</root>", "2 trees and no main_tree_to_execute"),
        (tree("<SubTree name='S'/>", WAIT), "a SubTree needs an ID"),
    ],
)
def test_broken_tree_files_get_one_line_naming_the_file(tmp_path: Path, content: str,
                                                        problem: str) -> None:
    tree = tmp_path / "broken.xml"
    tree.write_text(content)
    result = run("--tree", str(tree), cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "broken.xml" in lines[0] and problem in lines[0]
    assert not (tmp_path / "runs").exists(), "the simulator's head start is taken back"


def test_a_tree_files_structure_is_checked_before_anything_starts(tmp_path: Path) -> None:
    """What needs no behaviour imported is refused with the arguments, before the simulator's
    head start; a node the tree names is checked while the simulator comes up."""
    from bt_servicesim.cli import UsageError
    from bt_servicesim.run import build_parser, settings_from

    def settings_for(content: str) -> object:
        (tmp_path / "broken.xml").write_text(content)
        arguments = ["--tree", str(tmp_path / "broken.xml"), "--out", str(tmp_path / "run")]
        return settings_from(build_parser().parse_args(arguments))

    for content, problem in [("<tree/>", "expected <root>"),
                             (tree("<SubTree ID='W' name='S'/>", WAIT + WAIT),
                              'two <BehaviorTree ID="W">')]:
        with pytest.raises(UsageError, match="broken.xml: .*" + problem):
            settings_for(content)
    assert settings_for(tree("<Teleport name='T'/>")) is not None
    assert not (tmp_path / "run").exists()


def test_a_refused_tree_keeps_the_earlier_run_it_was_to_overwrite(tmp_path: Path) -> None:
    """The simulator starts while the tree's nodes are checked; its log has a name of its own
    until the tree passes, and goes with the simulator when it does not."""
    earlier = tmp_path / "earlier"
    earlier.mkdir()
    (earlier / "report.json").write_text('{"status": "completed"}')
    (earlier / "sim.log").write_text("the earlier run's simulator\n")
    broken = tmp_path / "broken.xml"
    broken.write_text(tree("<Teleport name='T'/>"))  # a node no behaviour plays
    result = run("--tree", str(broken), "--out", str(earlier), "--overwrite", cwd=tmp_path)
    assert result.returncode == 2 and "broken.xml" in result.stderr
    assert sorted(path.name for path in earlier.iterdir()) == ["report.json", "sim.log"]
    assert (earlier / "sim.log").read_text() == "the earlier run's simulator\n"


@pytest.mark.parametrize(("arguments", "problem"), [
    pytest.param(["--world", "missing_map.yaml"],
                 "missing_map.yaml: map nowhere.yaml: no such file", id="world"),
    pytest.param(["--sim-arg=--frobnicate"], "unrecognized arguments: --frobnicate",
                 id="sim-arg"),
    pytest.param(["--nav-params", "integer_scaling.yaml"],
                 "integer_scaling.yaml: global_costmap.global_costmap.ros__parameters."
                 "inflation_layer.cost_scaling_factor: must be a double", id="nav-params"),
])
def test_input_the_simulator_refuses_writes_nothing_and_keeps_an_earlier_run(
        tmp_path: Path, arguments: list[str], problem: str) -> None:
    """The simulator checks the world (and its own arguments) before the run takes its
    directory: a refusal leaves an earlier run as it was, and makes no fresh directory."""
    (tmp_path / "missing_map.yaml").write_text("name: broken\nmap: nowhere.yaml\n")
    (tmp_path / "integer_scaling.yaml").write_text(
        "global_costmap:\n  global_costmap:\n    ros__parameters:\n"
        "      inflation_layer:\n        cost_scaling_factor: 10\n")
    earlier = tmp_path / "earlier"
    earlier.mkdir()
    kept = {"report.json": '{"status": "completed"}', "sim.log": "the earlier simulator\n",
            "run.mcap": "earlier", "tree_log.jsonl": "earlier", "final_tree.txt": "earlier",
            "trajectory.png": "earlier"}
    for name, text in kept.items():
        (earlier / name).write_text(text)
    result = run(*arguments, "--out", str(earlier), "--overwrite", cwd=tmp_path)
    assert result.returncode == 2
    (line,) = result.stderr.strip().splitlines()
    assert problem in line
    assert {path.name: path.read_text() for path in earlier.iterdir()} == kept
    fresh = run(*arguments, "--out", "fresh/run", cwd=tmp_path)
    assert fresh.returncode == 2 and problem in fresh.stderr
    assert not (tmp_path / "fresh").exists(), "exit 2: nothing was started, nothing written"


def test_nav_params_is_a_file_the_run_passes_on_and_no_sim_arg_or_attached_backend_takes(
        tmp_path: Path) -> None:
    from bt_servicesim.cli import UsageError
    from bt_servicesim.run import build_parser, settings_from
    from bt_servicesim.tree.files import DEFAULT_NAV_PARAMS

    params = tmp_path / "mine.yaml"
    params.write_text("controller_server:\n  ros__parameters: {}\n")
    out = ["--out", str(tmp_path / "run")]
    given = settings_from(build_parser().parse_args(["--nav-params", str(params), *out]))
    assert given.nav_params == params.resolve()
    assert settings_from(build_parser().parse_args(out)).nav_params == DEFAULT_NAV_PARAMS
    baseline = ["--executive", "baseline", *out]
    assert settings_from(build_parser().parse_args(baseline)).nav_params is None
    servicebot = ["--nav-params", "servicebot", *out]
    assert settings_from(build_parser().parse_args(servicebot)).nav_params is None
    assert settings_from(build_parser().parse_args([*out, "--attach"])).nav_params is None
    for arguments, problem in (
            (["--nav-params", str(tmp_path / "missing.yaml")], "missing.yaml: no such file"),
            (["--nav-params", str(tmp_path)], "is a directory, not a parameters file"),
            (["--nav-params", str(params), "--attach"], "--attach starts no simulator: "
                                                        "--nav-params would not reach"),
            ([f"--sim-arg=--nav-params={params}"], "the run sets --nav-params itself")):
        with pytest.raises(UsageError, match=problem):
            settings_from(build_parser().parse_args([*arguments, *out]))
