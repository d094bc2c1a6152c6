"""Where the people's points were booked (:mod:`bt_servicesim.evaluation.passages`): in a
passage too narrow to pass anyone outside the zone, by who moved, or where there was room.

The map: a 1.6 m corridor (x 0..8, y 4.0..5.6) opening into a 6 x 6 m hall (x 8..14)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bt_servicesim.evaluation.passages import KINDS, Tally, Track, classify, table_lines
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from tests.fakes.commands import run_module
from tests.fakes.maps import cells, fill, grid_message

ROBOT_PASSING, BOTH_MOVING, ROBOT_STANDING = KINDS


def corridor_and_hall() -> OccupancyGrid2D:
    values = cells(14.0, 10.0)
    fill(values, 0.0, 0.0, 14.0, 10.0)
    fill(values, 0.0, 4.0, 8.0, 5.6, value=0)
    fill(values, 8.0, 2.0, 14.0, 8.0, value=0)
    return OccupancyGrid2D.from_message(grid_message(values))


GRID = corridor_and_hall()


def track(*, robot: tuple[float, float], speed: float, walker: tuple[float, float],
          walker_step: float = 0.0) -> Track:
    """Samples at 0.5 s from 0 to 2 s: the robot still at ``robot`` with ``speed``, the walker
    at ``walker`` moving ``walker_step`` metres along x each sample, an idler far off."""
    times = [0.5 * k for k in range(5)]
    people = [{"w": ("walker", walker[0] + walker_step * k, walker[1]),
               "i": ("idler", 12.0, 7.5)} for k in range(5)]
    return Track(robot_times=times, robot=[(*robot, speed)] * 5, people_times=times,
                 people=people)


def tallied(bookings: list[tuple[float, str, float]], *tracks: Track) -> Tally:
    tally = Tally()
    for one in tracks:
        classify(bookings, one, GRID, tally)
    return tally


def test_driving_past_a_walker_standing_in_the_corridor_is_a_narrow_passing() -> None:
    tally = tallied([(1.0, "approximation/walker", 30.0), (1.1, "approximation/walker", 20.0)],
                    track(robot=(4.0, 4.5), speed=0.5, walker=(4.6, 5.1)))
    assert tally.points == {"walker": 50.0}
    assert tally.narrow == {("walker", ROBOT_PASSING): 50.0}


@pytest.mark.parametrize(("speed", "step", "kind"), [(0.5, 0.6, BOTH_MOVING),
                                                     (0.0, 0.6, ROBOT_STANDING),
                                                     (0.0, 0.0, ROBOT_STANDING)])
def test_who_moved_is_told_from_the_robots_speed_and_the_persons_steps(
        speed: float, step: float, kind: str) -> None:
    tally = tallied([(1.0, "approximation/walker", 10.0)],
                    track(robot=(4.0, 4.5), speed=speed, walker=(4.6, 5.1), walker_step=step))
    assert tally.narrow == {("walker", kind): 10.0}


def test_points_where_there_was_room_count_but_not_as_narrow() -> None:
    tally = tallied([(1.0, "approximation/walker", 10.0)],
                    track(robot=(11.0, 5.0), speed=0.5, walker=(11.6, 5.4)))
    assert tally.points == {"walker": 10.0} and not tally.narrow


def test_the_booked_role_picks_the_person_and_walls_and_other_causes_are_left_out() -> None:
    tally = tallied([(1.0, "approximation/idler", 4.0), (1.0, "approximation/walls", 9.0),
                     (1.0, "failed_pickup", 40.0)],
                    track(robot=(11.0, 5.0), speed=0.5, walker=(4.6, 5.1)))
    assert tally.points == {"idler": 4.0}  # the idler, in the hall with the robot: room to pass
    assert not tally.narrow  # the walker in the corridor is not whom the booking was for


def test_the_table_gives_points_an_episode_and_the_narrow_share() -> None:
    walker = track(robot=(4.0, 4.5), speed=0.5, walker=(4.6, 5.1))
    hall = track(robot=(11.0, 5.0), speed=0.5, walker=(11.6, 5.4))
    tally = tallied([(1.0, "approximation/walker", 30.0)], walker, hall)
    lines = table_lines(tally, narrow=2.2)
    assert lines[0] == "2 episodes; points an episode; in passages under 2.2 m"
    assert lines[3] == "| walker | 30.0 | 15.0 (50%) | 15.0 | 0.0 | 0.0 |"


@pytest.mark.parametrize(("arguments", "message"), [
    ((), "summary.json"),
    (("--narrow", "0"), "--narrow 0: must be more than 0"),
])
def test_bad_input_gets_one_line_and_exit_2(tmp_path: Path, arguments: tuple[str, ...],
                                            message: str) -> None:
    (tmp_path / "summary.json").write_text(json.dumps({"bt": {"rows": []}}))
    done = run_module("bt_servicesim.evaluation.passages", str(tmp_path), *arguments)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], done.stderr


def write_episode(out: Path) -> None:
    """An episode's records: a profile with two walker bookings at 1.0 s, and a recording of
    the map, the robot driving up the corridor and a walker standing in it."""
    from geometry_msgs.msg import Point
    from mcap.writer import Writer
    from nav_msgs.msg import OccupancyGrid, Odometry
    from rclpy.serialization import serialize_message
    from servicesim_competition.msg import ActorStates

    from bt_servicesim.records.mcap import GROUND_TRUTH_TOPIC, complete_definition, type_name

    out.mkdir(parents=True)
    (out / "profile.json").write_text(json.dumps({"timeline": {"bookings": [
        [1.0, "approximation/walker", 30.0], [1.0, "approximation/walls", 5.0]]}}))
    map_message = grid_message(np.asarray(GRID.values, dtype=np.int8))
    messages: list[tuple[str, object]] = [("/servicebot/map", map_message)]
    for step in range(5):
        odometry = Odometry()
        odometry.pose.pose.position.x, odometry.pose.pose.position.y = 3.0 + 0.25 * step, 4.5
        odometry.twist.twist.linear.x = 0.5
        actors = ActorStates(names=["human_1"], roles=["walker"],
                             positions=[Point(x=4.6, y=5.1, z=0.0)])
        messages += [(GROUND_TRUTH_TOPIC, odometry), ("/servicesim/actors", actors)]
    with (out / "run.mcap").open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        channels = {}
        for topic, message_type in (("/servicebot/map", OccupancyGrid),
                                    (GROUND_TRUTH_TOPIC, Odometry),
                                    ("/servicesim/actors", ActorStates)):
            name = type_name(message_type)
            schema = writer.register_schema(name=name, encoding="ros2msg",
                                            data=complete_definition(name).encode())
            channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr",
                                                      schema_id=schema)
        for index, (topic, message) in enumerate(messages):
            when = int(index // 2 * 0.5e9)  # the map and the first samples at 0 s, then 0.5 s on
            writer.add_message(channel_id=channels[topic], log_time=when, publish_time=when,
                               data=serialize_message(message))
        writer.finish()


def test_the_command_reads_each_episodes_profile_and_recording(tmp_path: Path) -> None:
    write_episode(tmp_path / "bt" / "random" / "0")
    rows = [{"episode": 0, "scenario": "random", "episode_seed": 0, "completed": True,
             "score": 100.0, "checkpoints": [], "out": str(tmp_path / "bt" / "random" / "0")}]
    (tmp_path / "summary.json").write_text(json.dumps({"bt": {"rows": rows}}))
    done = run_module("bt_servicesim.evaluation.passages", str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[3] == "| walker | 30.0 | 30.0 (100%) | 30.0 | 0.0 | 0.0 |"
