"""``benchmarks/cpu_per_sim_second.py``'s check that two checkouts recorded the same mission:
what differs in a run's records is named, what a run's wall clock or identity decides is not."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

from rclpy.serialization import serialize_message
from std_msgs.msg import String

REPO = Path(__file__).resolve().parents[2]
JOIN_NS = 100_000_000


def benchmark() -> Any:
    """The script as a module (it is a script, not a package; it imports its neighbours)."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    spec = importlib.util.spec_from_file_location(
        "cpu_per_sim_second_benchmark", REPO / "benchmarks" / "cpu_per_sim_second.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def records(root: Path, checkout: Path, *, report: dict[str, Any] | None = None,
            messages: list[tuple[str, int, str]] | None = None, log: str = "") -> Any:
    """A run's directory as the run writes it; its :class:`Run`."""
    from mcap.writer import Writer

    root.mkdir(parents=True)
    base = {"run_id": "a", "ros_domain_id": 3, "wall_time_s": 1.0, "task_timing": {},
            "score": 100.0, "tree": f"{checkout}/trees/mission.xml"}
    (root / "report.json").write_text(json.dumps({**base, **(report or {})}))
    (root / "tree_log.jsonl").write_text(f'{{"tree_file": "{checkout}/trees/x.xml"}}\n' + log)
    with (root / "run.mcap").open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(name="std_msgs/msg/String", encoding="ros2msg",
                                        data=b"string data")
        channels: dict[str, int] = {}
        for topic, log_time, text in messages or []:
            if topic not in channels:
                channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr",
                                                          schema_id=schema)
            writer.add_message(channel_id=channels[topic], log_time=log_time,
                               publish_time=log_time,
                               data=serialize_message(String(data=text)))
        writer.finish()
    return benchmark().Run(cpu_s=1.0, simulator_cpu_s=0.5, sim_s=10.0, period_costs=None,
                           records=root)


MISSION = [("/tf", JOIN_NS, "before the join"), ("/tf", 2 * JOIN_NS, "a"),
           ("/odom", 3 * JOIN_NS, "b"), ("/tf", 5 * JOIN_NS, "after the leaving")]


def test_the_same_mission_in_two_checkouts_is_identical(tmp_path: Path) -> None:
    this, other = tmp_path / "this", tmp_path / "other"
    first = records(tmp_path / "a", this, report={"run_id": "x", "wall_time_s": 9.0},
                    messages=MISSION)
    second = records(tmp_path / "b", other, report={"ros_domain_id": 7},
                     messages=[(topic, time, text.replace("after", "still after"))
                               if time == 5 * JOIN_NS else (topic, time, text)
                               for topic, time, text in MISSION][1:])
    assert benchmark().record_differences(first, second, (this, other)) == []


def test_what_the_mission_decides_is_named_when_it_differs(tmp_path: Path) -> None:
    this, other = tmp_path / "this", tmp_path / "other"
    first = records(tmp_path / "a", this, messages=MISSION, log='{"tick": 1}\n')
    second = records(tmp_path / "b", other, report={"score": 101.0},
                     messages=[(topic, time, "c" if text == "b" else text)
                               for topic, time, text in MISSION], log='{"tick": 2}\n')
    assert benchmark().record_differences(first, second, (this, other)) == [
        "report.json score", "tree_log.jsonl", "run.mcap /odom"]
