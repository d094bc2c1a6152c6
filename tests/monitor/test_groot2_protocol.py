"""The Groot2 protocol's bytes, without a socket: headers, status buffers, blackboards, errors."""

from __future__ import annotations

import dataclasses
import enum
import struct

import msgpack
import numpy as np
import pytest

from bt_servicesim.monitor.groot2_protocol import (
    REPLY_HEADER_SIZE,
    RequestHeader,
    RequestType,
    Served,
    answer,
    blackboard_payload,
    jsonable,
    status_buffer,
)

TREE_ID = bytes(range(16))


def served(**entries: object) -> Served:
    return Served(tree_id=TREE_ID, tree_xml="<root/>", statuses=[1, 2, 3],
                  blackboards=lambda: {"Main": dict(entries)})


def request(kind: str, unique_id: int = 0xA1B2C3D4) -> bytes:
    return RequestHeader(request_type=ord(kind), unique_id=unique_id).to_bytes()


def test_a_request_header_is_protocol_type_then_little_endian_id() -> None:
    frame = request("S", 0x01020304)
    assert frame == b"\x02S\x04\x03\x02\x01"
    assert RequestHeader.from_bytes(frame) == RequestHeader(request_type=ord("S"),
                                                            unique_id=0x01020304)


def test_a_reply_echoes_the_request_header_and_carries_the_tree_id() -> None:
    header, xml = answer([request("T", 77)], served())
    assert len(header) == REPLY_HEADER_SIZE
    assert header[:6] == request("T", 77)
    assert header[6:] == TREE_ID
    assert xml == b"<root/>"


def test_the_status_buffer_is_uid_then_status_for_every_node() -> None:
    _, buffer = answer([request("S")], served())
    assert buffer == status_buffer([1, 2, 3])
    assert list(struct.iter_unpack("<HB", buffer)) == [(1, 1), (2, 2), (3, 3)]


def test_the_blackboard_is_messagepack_of_the_named_blackboards() -> None:
    _, payload = answer([request("B"), b"Main;Unknown"], served(x=3, s="hi", f=1.5))
    assert msgpack.unpackb(payload) == {"Main": {"x": 3, "s": "hi", "f": 1.5}}


def test_a_blackboard_request_naming_nothing_known_is_nil_as_btcpp_answers() -> None:
    assert blackboard_payload("", {"Main": {"x": 1}}) == msgpack.packb(None)
    assert msgpack.unpackb(blackboard_payload("Main", {"Main": {}})) == {"Main": None}


@pytest.mark.parametrize("frames", [[request("B")], [request("B"), b"a", b"b"]])
def test_a_blackboard_request_without_exactly_one_name_frame_is_an_error(
        frames: list[bytes]) -> None:
    assert answer(frames, served()) == [b"error", b"must be 2 parts message"]


@pytest.mark.parametrize("kind", ["I", "R", "U", "r", "t"])
def test_hooks_breakpoints_and_recording_get_the_error_answer(kind: str) -> None:
    error, message = answer([request(kind), b"{}"], served())
    assert error == b"error"
    assert b"not supported" in message


def test_there_are_never_hooks_to_dump_remove_or_disable() -> None:
    assert answer([request("D")], served())[1] == b"[]"
    assert len(answer([request("A")], served())) == 1
    assert len(answer([request("X")], served())) == 1


@pytest.mark.parametrize(("frames", "message"), [
    ([b"\x02S"], b"wrong request header"),
    ([], b"empty request"),
    ([request("?")], b"Request not recognized"),
])
def test_malformed_requests_get_the_error_answer(frames: list[bytes], message: bytes) -> None:
    assert answer(frames, served()) == [b"error", message]


def test_every_request_type_of_the_protocol_is_known() -> None:
    assert {chr(kind) for kind in RequestType} == set("TSBIRNUDAXrt")


class Colour(enum.Enum):
    RED = 1


@dataclasses.dataclass
class Pose:
    x: float
    y: float
    _cache: dict[str, object] = dataclasses.field(default_factory=dict)


def test_values_json_cannot_hold_are_made_readable() -> None:
    assert jsonable(Pose(1.0, 2.0, {"big": "cache"})) == {"__type": "Pose", "x": 1.0, "y": 2.0}
    assert jsonable(np.zeros((600, 400), dtype=np.int8)) == "ndarray int8 (600, 400)"
    assert jsonable({"c": Colour.RED, 2: (1, {3})}) == {"c": "RED", "2": [1, [3]]}
    assert jsonable(float("nan")) is None
    assert jsonable(object()).startswith("<object object")


def test_a_value_that_contains_itself_is_cut_off_not_a_recursion_error() -> None:
    loop: list[object] = []
    loop.append(loop)
    flat = jsonable(loop)
    depth = 0
    while isinstance(flat, list):
        flat, depth = flat[0], depth + 1
    assert isinstance(flat, str) and depth == 8
    msgpack.packb(jsonable({"loop": loop}))
