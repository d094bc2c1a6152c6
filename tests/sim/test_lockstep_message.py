"""The lockstep announcement, serialised by hand: what rclpy would send, field for field and in
length, for varied names (lengths that move the alignment, none at all) and counts, and again
after names were added; and the done messages, read by hand as rclpy reads them."""

from __future__ import annotations

import struct

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from servicesim_competition.msg import LockstepDone, LockstepPeriod

from servicesim_sim.lockstep.gate import Reading
from servicesim_sim.lockstep.message import (
    AnnouncementBytes,
    Done,
    DoneReader,
    done_of,
    read_done,
)

NAMES = ["/clock", "/tf", "/a", "/ab", "/abc", "/abcd", "/servicebot/odom",
         "/servicebot/navigate_to_pose:feedback", "/servicesim/room_info", "/x:goal"]


def by_rclpy(period: int, sim_time_ns: int, messages: dict[str, int], served: set[str],
             answers: dict[str, int]) -> bytes:
    message = LockstepPeriod(period=period)
    message.sim_time.sec, message.sim_time.nanosec = divmod(sim_time_ns, 1_000_000_000)
    message.topics = sorted(messages)
    message.messages = [messages[topic] for topic in message.topics]
    message.endpoints = sorted(served | set(answers))
    message.answers = [answers.get(endpoint, 0) for endpoint in message.endpoints]
    return serialize_message(message)


def check(encoder: AnnouncementBytes, period: int, sim_time_ns: int, messages: dict[str, int],
          served: set[str], answers: dict[str, int]) -> LockstepPeriod:
    ours = encoder.encode(period=period, sim_time_ns=sim_time_ns, messages=messages,
                          served=served, answers=answers)
    theirs = by_rclpy(period, sim_time_ns, messages, served, answers)
    assert len(ours) == len(theirs)
    read = deserialize_message(ours, LockstepPeriod)
    assert read == deserialize_message(theirs, LockstepPeriod)
    return read


@pytest.mark.parametrize("topics", [0, 1, 2, 3, 5, 10])
@pytest.mark.parametrize("served", [0, 1, 4])
@pytest.mark.parametrize("answered", [0, 1, 3])
def test_the_announcement_is_rclpys_own(topics: int, served: int, answered: int) -> None:
    messages = {name: 7 * index + 1 for index, name in enumerate(NAMES[:topics])}
    serving = set(NAMES[-served:]) if served else set()
    answers = {name: 2**40 + index for index, name in enumerate(NAMES[2:2 + answered])}
    read = check(AnnouncementBytes(), 12345, 1_234_500_000_001, messages, serving, answers)
    assert read.period == 12345
    assert (read.sim_time.sec, read.sim_time.nanosec) == (1234, 500_000_001)
    assert dict(zip(read.topics, read.messages, strict=True)) == messages


def test_new_names_lay_the_announcement_out_again() -> None:
    encoder = AnnouncementBytes()
    messages: dict[str, int] = {}
    served: set[str] = {"/servicesim/room_info"}
    answers: dict[str, int] = {}
    for period, name in enumerate(NAMES, start=1):
        check(encoder, period, period * 100_000_000, messages, served, answers)
        messages[name] = period
        answers[name[::-1]] = period * 3
        check(encoder, period, period * 100_000_000, messages, served, answers)
        messages[name] += 1
        read = check(encoder, period + 1, period * 100_000_000, messages, served, answers)
        assert read.messages[read.topics.index(name)] == period + 1
    served.add("/servicesim/new_one")
    read = check(encoder, 99, 0, messages, served, answers)
    assert "/servicesim/new_one" in read.endpoints


@pytest.mark.parametrize("endpoints", [[], ["/a"], ["/ab", "/abc"], ["/abcd"], NAMES])
@pytest.mark.parametrize("leaving", [False, True])
@pytest.mark.parametrize(("client", "period"), [(0, 0), (1, 5), (2**32 - 1, 2**64 - 1)])
@pytest.mark.parametrize("reading", [[], ["/servicebot/camera_front/image_raw"], ["/a", "/bc"]])
def test_a_done_reads_as_rclpy_reads_it(endpoints: list[str], leaving: bool, client: int,
                                        period: int, reading: list[str]) -> None:
    requests = [3 * index + 2**33 * (index % 2) for index in range(len(endpoints))]
    starts = [period // 2 + index for index in range(len(reading))]
    message = LockstepDone(client=client, period=period, endpoints=endpoints,
                           requests=requests, leaving=leaving, reading_topics=reading,
                           reading_from=starts)
    data = serialize_message(message)
    assert read_done(data) == done_of(message) == Done(
        client=client, period=period, leaving=leaving,
        requests=dict(zip(endpoints, requests, strict=True)),
        readings=tuple(Reading(topic=topic, start=start)
                       for topic, start in zip(reading, starts, strict=True)))


def test_a_done_in_big_endian_cdr_is_read_by_rclpy() -> None:
    message = LockstepDone(client=7, period=9, endpoints=["/a"], requests=[1])
    data = bytearray(serialize_message(message))
    assert read_done(bytes(data)) == done_of(message)
    big = b"\x00\x00\x00\x00" + struct.pack(">I4xQI", 7, 9, 1) + struct.pack(">I", 3) + b"/a\x00"
    big += b"\x00" + struct.pack(">I", 1) + struct.pack(">Q", 1) + b"\x00"
    big += b"\x00" * 3 + struct.pack(">II", 0, 0)  # no readings
    assert read_done(big) == done_of(message) == done_of(deserialize_message(big, LockstepDone))


def test_a_reader_reads_each_done_right_as_the_names_change() -> None:
    reader = DoneReader()
    names = [[], ["/ab"], ["/ab"], ["/ba"], ["/ab", "/cd"], ["/abc", "/d"], ["/abc", "/d"],
             ["/ab"], NAMES, NAMES, NAMES[1:], []]
    for period, endpoints in enumerate(names):
        message = LockstepDone(client=3, period=period, endpoints=endpoints,
                               requests=[period + index for index in range(len(endpoints))],
                               leaving=period == len(names) - 1)
        assert reader.read(serialize_message(message)) == done_of(message)


def test_a_reader_reads_each_done_right_when_only_its_period_or_one_number_changes() -> None:
    reader = DoneReader()
    same = {"client": 3, "endpoints": ["/ab", "/cd"], "requests": [1, 2]}
    changes: list[dict[str, object]] = [
        {}, {}, {"requests": [1, 3]}, {"requests": [1, 3]}, {"client": 4},
        {"reading_topics": ["/cam"], "reading_from": [9]},
        {"reading_topics": ["/cam"], "reading_from": [10]}, {}, {"leaving": True}, {}]
    for period, change in enumerate(changes):
        message = LockstepDone(**{**same, "period": period, **change})
        data = bytearray(serialize_message(message))
        data[8:12] = b"\xff\xff\xff\xff"  # padding: rclpy leaves what memory held there
        assert reader.read(bytes(data)) == done_of(message)
