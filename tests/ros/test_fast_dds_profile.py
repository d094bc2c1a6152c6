"""The Fast DDS profile both processes default to on loopback: two shorter periods and nothing
else, never in place of a profile the user chose.

The executive and the simulator each ship a copy (they share no code), so every check here runs
on both.
"""

from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable, Mapping
from pathlib import Path

import pytest

from bt_servicesim.ros import environment as executive_environment
from servicesim_sim.process import environment as simulator_environment

NAMESPACE = "{http://www.eprosima.com}"
PROFILES = {"executive": executive_environment.FAST_DDS_PROFILE,
            "simulator": simulator_environment.FAST_DDS_PROFILE}
JUDGES: dict[str, Callable[..., bool]] = {
    "executive": executive_environment.uses_the_projects_profile,
    "simulator": simulator_environment.reads_the_simulators_profile,
}
PERIODS = {"/participant/rtps/builtin/discovery_config/leaseAnnouncement": "500000000",
           "/data_writer/times/heartbeat_period": "100000000"}  # ns


def _settings(path: Path) -> dict[str, str]:
    """Every leaf of the profile, by its path of tags: what it sets."""
    leaves: dict[str, str] = {}

    def walk(element: ElementTree.Element, trail: str) -> None:
        children = list(element)
        if not children:
            leaves[trail] = (element.text or "").strip()
        for child in children:
            walk(child, f"{trail}/{child.tag.removeprefix(NAMESPACE)}")

    walk(ElementTree.parse(path).getroot(), "")
    return leaves


@pytest.mark.parametrize("process", PROFILES)
def test_the_profile_sets_only_the_announcement_and_heartbeat_periods(process: str) -> None:
    """Nothing about transports or addresses: rmw_fastrtps keeps traffic on loopback."""
    assert _settings(PROFILES[process]) == {
        f"{where}/{unit}": value for where, nanoseconds in PERIODS.items()
        for unit, value in (("sec", "0"), ("nanosec", nanoseconds))}


@pytest.mark.parametrize("process", PROFILES)
def test_fast_dds_reads_the_profile_without_an_error(process: str) -> None:
    """Fast DDS logs an element it does not know and drops the whole profile."""
    program = ("import rclpy; from std_msgs.msg import Empty; rclpy.init(); "
               "node = rclpy.create_node('profile_check'); "
               "node.create_publisher(Empty, 'profile_check', 1); node.destroy_node(); "
               "rclpy.shutdown()")
    environment = {**os.environ, "FASTDDS_DEFAULT_PROFILES_FILE": str(PROFILES[process])}
    result = subprocess.run([sys.executable, "-c", program], env=environment,
                            capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 0, result.stderr
    assert "XMLPARSER" not in result.stderr


def test_the_two_copies_agree() -> None:
    assert _settings(PROFILES["executive"]) == _settings(PROFILES["simulator"])
    for name in ("USER_PROFILE_VARIABLES", "USER_PROFILE_FILES", "FAST_DDS_IMPLEMENTATIONS"):
        assert getattr(executive_environment, name) == getattr(simulator_environment, name)


@pytest.mark.parametrize("process", JUDGES)
@pytest.mark.parametrize(("environment", "read"), [
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, True),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"},
     True),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}, False),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"},
     False),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
      "FASTDDS_DEFAULT_PROFILES_FILE": "/home/user/mine.xml"}, False),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
      "FASTRTPS_DEFAULT_PROFILES_FILE": "/home/user/mine.xml"}, False),
], ids=["loopback", "fast-dds-named", "subnet", "cyclone", "user-profile", "legacy-variable"])
def test_the_profile_is_read_on_loopback_with_fast_dds_unless_the_user_names_one(
        process: str, environment: Mapping[str, str], read: bool, tmp_path: Path) -> None:
    assert JUDGES[process](environment, working_directory=tmp_path) is read


@pytest.mark.parametrize("process", JUDGES)
@pytest.mark.parametrize("name", ["DEFAULT_FASTDDS_PROFILES.xml", "DEFAULT_FASTRTPS_PROFILES.xml"])
def test_a_profile_kept_in_the_working_directory_wins(process: str, name: str,
                                                       tmp_path: Path) -> None:
    (tmp_path / name).write_text("<profiles/>")
    environment = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    assert not JUDGES[process](environment, working_directory=tmp_path)


def test_the_executive_names_the_profile_for_itself_and_its_children(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    child: dict[str, str] = {}
    executive_environment.apply_localhost_defaults(child)
    assert child["FASTDDS_DEFAULT_PROFILES_FILE"] == str(PROFILES["executive"])
    mine = {"FASTDDS_DEFAULT_PROFILES_FILE": "/home/user/mine.xml"}
    executive_environment.apply_localhost_defaults(mine)
    assert mine["FASTDDS_DEFAULT_PROFILES_FILE"] == "/home/user/mine.xml"


def test_the_simulator_keeps_the_profile_its_executive_named(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(simulator_environment, "remove_dead_segments", lambda *a, **k: [])
    monkeypatch.setattr(simulator_environment, "_at_exit_registered", True)
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("FASTDDS_DEFAULT_PROFILES_FILE", str(PROFILES["executive"]))
    simulator_environment.apply_environment_defaults()
    assert os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(PROFILES["executive"])
    monkeypatch.delenv("FASTDDS_DEFAULT_PROFILES_FILE")
    simulator_environment.apply_environment_defaults()
    assert os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(PROFILES["simulator"])


def test_the_simulator_publishes_synchronously_whatever_the_user_set(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(simulator_environment, "remove_dead_segments", lambda *a, **k: [])
    monkeypatch.setattr(simulator_environment, "_at_exit_registered", True)
    for chosen in (None, "ASYNCHRONOUS", "AUTO"):
        if chosen is None:
            monkeypatch.delenv("RMW_FASTRTPS_PUBLICATION_MODE", raising=False)
        else:
            monkeypatch.setenv("RMW_FASTRTPS_PUBLICATION_MODE", chosen)
        simulator_environment.apply_environment_defaults()
        assert os.environ["RMW_FASTRTPS_PUBLICATION_MODE"] == "SYNCHRONOUS"
