"""Ask the server at a ``--cluster`` address what it is, bounded in time and in size.

Dask's own client trusts what answers: its connect waits for the server's handshake without a
time limit (a listener that accepts and never replies holds it for ever), and it reads each
message's length from the first eight bytes and allocates that much before it reads the rest
(a server of another protocol makes it allocate whatever its first bytes say). So before a
:class:`distributed.Client` is made, :func:`server_kind` speaks Dask's TCP framing itself for
the two messages that say who the server is -- the handshake and an ``identity`` request --
with the whole exchange bounded by a time limit and each answer by :data:`MAX_ANSWER_BYTES`.
Anything else is a :class:`ProbeError` whose message says what was wrong.

The framing is Dask's small-message form: an 8-byte little-endian length, then the frames'
count and lengths (8 bytes each) and the frames, as ``distributed.protocol.utils.pack_frames``
lays them out, each message serialised by ``distributed.protocol.dumps``.
"""

from __future__ import annotations

import asyncio
import pickle
import struct
import sys
from typing import Any
from urllib.parse import urlsplit

from distributed.protocol.core import dumps, loads
from distributed.protocol.utils import pack_frames, unpack_frames

__all__ = ["MAX_ANSWER_BYTES", "ProbeError", "server_kind"]

MAX_ANSWER_BYTES = 1 << 20
"""The most an answer may take: a scheduler's handshake and identity are a few kilobytes (its
identity lists its workers, some hundred bytes each)."""
_LENGTH = struct.Struct("<Q")


class ProbeError(Exception):
    """What answers does not answer as a Dask server: the message says how."""


async def server_kind(address: str, *, timeout_s: float) -> str:
    """What the Dask server at ``address`` (``tcp://host:port``) says it is: ``Scheduler``,
    ``Worker``...; :class:`ProbeError` if what answers does not speak Dask's protocol,
    ``TimeoutError`` if it does not answer within ``timeout_s``, ``OSError`` if nothing
    listens."""
    parts = urlsplit(address)
    return await asyncio.wait_for(_ask(str(parts.hostname), int(parts.port or 0)),
                                  timeout=timeout_s)


async def _ask(host: str, port: int) -> str:
    reader, writer = await asyncio.open_connection(host, port)
    try:
        _send(writer, {"compression": None, "python": tuple(sys.version_info)[:3],
                       "pickle-protocol": pickle.HIGHEST_PROTOCOL})
        await writer.drain()
        await _receive(reader)  # its handshake
        _send(writer, {"op": "identity", "reply": True})
        await writer.drain()
        identity = await _receive(reader)
    finally:
        writer.close()
    if not isinstance(identity, dict):
        raise ProbeError("its answer to who it is was no Dask identity")
    return str(identity.get("type", "server of unknown kind"))


def _send(writer: asyncio.StreamWriter, message: dict[str, Any]) -> None:
    packed = pack_frames(dumps(message))
    writer.write(_LENGTH.pack(len(packed)) + packed)


async def _receive(reader: asyncio.StreamReader) -> Any:
    try:
        (length,) = _LENGTH.unpack(await reader.readexactly(_LENGTH.size))
        if length > MAX_ANSWER_BYTES:
            raise ProbeError(f"it announced an answer of {length} bytes, where Dask's is a few "
                             f"kilobytes (at most {MAX_ANSWER_BYTES} taken)")
        body = await reader.readexactly(length)
    except asyncio.IncompleteReadError:
        raise ProbeError("it closed the connection without a Dask answer") from None
    try:
        return loads(unpack_frames(body))
    except Exception as error:  # msgpack's and Dask's many kinds: not Dask's framing
        raise ProbeError(f"its answer is not Dask's framing ({type(error).__name__})") from None
