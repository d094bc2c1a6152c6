"""BehaviorTree.CPP v4's Groot2 monitor protocol, as bytes: no sockets, no ROS, no py_trees.

Groot2 (and any client speaking to BehaviorTree.CPP's ``Groot2Publisher``) sends multipart ZMQ
requests to a REP socket. The first frame of a request is a 6-byte header:

    protocol id (uint8, 2) | request type (one ASCII char) | unique id (uint32, little endian)

and the first frame of every reply is that header echoed (protocol set to 2) followed by the
16 bytes of the tree's id, a random UUID fixed for the life of the server (22 bytes in all).
After the header:

- ``T`` (full tree): one frame, the tree as BehaviorTree.CPP XML whose nodes carry ``_uid``;
- ``S`` (status): one frame of 3 bytes a node, ``uid`` (uint16 LE) then its status (uint8:
  0 idle, 1 running, 2 success, 3 failure, 4 skipped; 10 + s for "idle, was s");
- ``B`` (blackboard, one extra request frame naming blackboards separated by ``;``): one
  frame, the MessagePack of ``{name: {key: value}}`` (nlohmann's ``to_msgpack`` of the JSON
  BehaviorTree.CPP builds), ``nil`` when no name was known.

A request this server cannot honour gets the protocol's error answer, two frames:
``b"error"`` and a message. This module answers requests given what to answer with
(:class:`Served`), so every byte the server sends is decided here and tested without a socket.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import reprlib
import struct
import uuid
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import msgpack

__all__ = [
    "DEFAULT_HOST", "DEFAULT_PORT", "PROTOCOL_ID", "REPLY_HEADER_SIZE", "REQUEST_HEADER_SIZE",
    "NodeStatusCode", "RequestHeader",
    "RequestType", "Served", "answer", "blackboard_payload", "error_reply", "jsonable",
    "new_tree_id", "reply_header", "status_buffer",
]

DEFAULT_HOST = "127.0.0.1"
"""Where a monitor listens unless told otherwise: loopback only."""
DEFAULT_PORT = 1667
"""Groot2's, Nav2's and btview's default port for a tree's monitor."""
PROTOCOL_ID = 2
REQUEST_HEADER_SIZE = 6
REPLY_HEADER_SIZE = REQUEST_HEADER_SIZE + 16
ERROR_FRAME = b"error"
MAX_DEPTH = 8
"""Levels of containers a blackboard value is walked into before it is shown as a repr."""
_HEADER = struct.Struct("<BBI")
_STATUS_ENTRY = struct.Struct("<HB")


class RequestType(enum.IntEnum):
    """The request types of ``groot2_protocol.h`` (the value is the ASCII code of the char)."""

    FULLTREE = ord("T")
    STATUS = ord("S")
    BLACKBOARD = ord("B")
    HOOK_INSERT = ord("I")
    HOOK_REMOVE = ord("R")
    BREAKPOINT_REACHED = ord("N")
    BREAKPOINT_UNLOCK = ord("U")
    HOOKS_DUMP = ord("D")
    REMOVE_ALL_HOOKS = ord("A")
    DISABLE_ALL_HOOKS = ord("X")
    TOGGLE_RECORDING = ord("r")
    GET_TRANSITIONS = ord("t")


class NodeStatusCode(enum.IntEnum):
    """BehaviorTree.CPP's ``NodeStatus`` as the status buffer carries it."""

    IDLE = 0
    RUNNING = 1
    SUCCESS = 2
    FAILURE = 3
    SKIPPED = 4


@dataclass(frozen=True)
class RequestHeader:
    """The first frame of a request; a reply echoes it."""

    request_type: int
    unique_id: int
    protocol: int = PROTOCOL_ID

    def to_bytes(self) -> bytes:
        return _HEADER.pack(self.protocol, self.request_type, self.unique_id)

    @classmethod
    def from_bytes(cls, frame: bytes) -> RequestHeader:
        """``ValueError`` unless ``frame`` is exactly one header long."""
        if len(frame) != REQUEST_HEADER_SIZE:
            raise ValueError("wrong request header")
        protocol, request_type, unique_id = _HEADER.unpack(frame)
        return cls(request_type=request_type, unique_id=unique_id, protocol=protocol)


def new_tree_id() -> bytes:
    """A random (version 4) UUID's 16 bytes, as the publisher makes one per server."""
    return uuid.uuid4().bytes


def reply_header(request: RequestHeader, *, tree_id: bytes) -> bytes:
    """The reply's first frame: the request's header (protocol 2) and the tree's id."""
    echoed = dataclasses.replace(request, protocol=PROTOCOL_ID)
    return echoed.to_bytes() + tree_id


def error_reply(message: str) -> list[bytes]:
    """The protocol's answer to a request it cannot honour."""
    return [ERROR_FRAME, message.encode()]


def status_buffer(codes: Sequence[int], *, first_uid: int = 1) -> bytes:
    """Every node's ``uid`` and status code; node ``i`` of ``codes`` has uid ``first_uid + i``."""
    buffer = bytearray(_STATUS_ENTRY.size * len(codes))
    for index, code in enumerate(codes):
        _STATUS_ENTRY.pack_into(buffer, _STATUS_ENTRY.size * index, first_uid + index, code)
    return bytes(buffer)


@dataclass(frozen=True)
class Served:
    """What the server answers with at the moment of a request.

    Attributes:
        tree_id: the 16 bytes identifying the tree for the server's life
        tree_xml: the full tree, BehaviorTree.CPP XML with ``_uid`` on every node
        statuses: the status code of every node, in uid order (uid 1 first)
        blackboards: blackboard name to its entries, for the names a client may ask for
    """

    tree_id: bytes
    tree_xml: str
    statuses: Sequence[int]
    blackboards: Callable[[], Mapping[str, Mapping[str, Any]]]


#: Requests answered with the header alone: there are never hooks to remove or disable.
_NOTHING_TO_DO = frozenset({RequestType.REMOVE_ALL_HOOKS, RequestType.DISABLE_ALL_HOOKS})


def answer(frames: Sequence[bytes], served: Served) -> list[bytes]:
    """The reply frames to one request's frames."""
    if not frames:
        return error_reply("empty request")
    try:
        request = RequestHeader.from_bytes(frames[0])
    except ValueError as error:
        return error_reply(str(error))
    header = reply_header(request, tree_id=served.tree_id)
    kind = request.request_type
    if kind == RequestType.FULLTREE:
        return [header, served.tree_xml.encode()]
    if kind == RequestType.STATUS:
        return [header, status_buffer(served.statuses)]
    if kind == RequestType.BLACKBOARD:
        if len(frames) != 2:
            return error_reply("must be 2 parts message")
        names = frames[1].decode(errors="replace")
        return [header, blackboard_payload(names, served.blackboards())]
    if kind == RequestType.HOOKS_DUMP:
        return [header, b"[]"]
    if kind in _NOTHING_TO_DO:
        return [header]
    if kind in RequestType.__members__.values():
        return error_reply(f"{RequestType(kind).name.lower()} is not supported by this executive")
    return error_reply("Request not recognized")


def blackboard_payload(names: str, blackboards: Mapping[str, Mapping[str, Any]]) -> bytes:
    """The MessagePack of ``{name: {key: value}}`` for the known names among ``names``
    (``;``-separated); ``nil`` when none is known, as BehaviorTree.CPP sends."""
    dump = {name: {key: jsonable(value) for key, value in blackboards[name].items()} or None
            for name in names.split(";") if name in blackboards}
    return msgpack.packb(dump or None, default=str, use_single_float=False)


def jsonable(value: Any, *, depth: int = 0) -> Any:
    """``value`` as JSON can hold it: containers walked, dataclasses as dicts of their public
    fields (with their type under ``__type``, as BehaviorTree.CPP's JSON exporter marks its own
    types; ``_`` fields are caches), arrays as their type, dtype and shape, enums by name,
    non-finite floats as ``null``; anything else as its ``str``. Below :data:`MAX_DEPTH`
    levels a value is its bounded ``repr`` (a cycle ends there too)."""
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, enum.Enum):
        return value.name
    if hasattr(value, "shape") and hasattr(value, "dtype"):  # numpy's, without importing it
        return f"{type(value).__name__} {value.dtype} {tuple(value.shape)}"
    if depth >= MAX_DEPTH:
        return reprlib.repr(value)
    inner = depth + 1
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {field.name: jsonable(getattr(value, field.name), depth=inner)
                  for field in dataclasses.fields(value) if not field.name.startswith("_")}
        return {"__type": type(value).__name__, **fields}
    if isinstance(value, Mapping):
        return {str(key): jsonable(item, depth=inner) for key, item in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [jsonable(item, depth=inner) for item in value]
    return str(value)
