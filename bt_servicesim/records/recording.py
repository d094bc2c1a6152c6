"""Read a run's ``run.mcap`` back: whole, or cut short, or not a recording at all.

A run closes its recording when it ends; an MCAP file that was closed ends with the format's
magic bytes after its summary, and is read with the summary's index. A run killed outright
(SIGKILL, a full disk, a machine that went down) leaves a file that stops mid-record, with no
summary: mcap's seeking reader then takes whatever bytes end the file for a footer and fails
with a record length of billions of gigabytes. Such a file is read front to back instead, every
message up to the last whole chunk, and :func:`recorded_messages` then says it was cut short
(:class:`RecordingCutShortError`); a file that is empty or not MCAP at all is a
:class:`RecordingError`. Each message is one line naming the file.

The people's ground truth, the largest messages read back, is read by :func:`recorded_people`
straight from its bytes (:func:`~bt_servicesim.ros.planar_cdr.people_states`), the same numbers
rclpy's deserialisation gives, without an object per person.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterable, Iterator
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Channel, Message
from rclpy.serialization import deserialize_message
from servicesim_competition.msg import ActorStates

from bt_servicesim.ros.planar_cdr import PeopleStates, people_states

__all__ = ["MCAP_MAGIC", "RecordingCutShortError", "RecordingError", "recorded_messages",
           "recorded_people"]

MCAP_MAGIC = b"\x89MCAP0\r\n"
"""The bytes an MCAP file begins with, and a closed one ends with."""


class RecordingError(ValueError):
    """A recording that cannot be read at all; the message is one line naming the file."""


class RecordingCutShortError(RecordingError):
    """A recording that stops mid-record; raised after the messages before the cut."""


def recorded_people(data: bytes) -> PeopleStates:
    """A recorded ``/servicesim/actors`` message (``ActorStates``) as :class:`PeopleStates`."""
    read = people_states(data)
    if read is not None:
        return read
    message = deserialize_message(data, ActorStates)  # not little-endian plain CDR
    return PeopleStates(names=[str(name) for name in message.names],
                        roles=[str(role) for role in message.roles],
                        positions=[(position.x, position.y) for position in message.positions],
                        guest_state=str(message.guest_state))


def recorded_messages(path: Path, *,
                      topics: Iterable[str]) -> Iterator[tuple[Channel, Message]]:
    """``topics``' messages in ``path`` in the order they were written.

    Raises :class:`RecordingError` before any message for a file that is not a recording,
    and :class:`RecordingCutShortError` after the last message that could be read for one cut
    short.
    """
    wanted = list(topics)
    try:
        with path.open("rb") as stream:
            closed = _closed(path, stream)
            size = path.stat().st_size
            reader = (make_reader(stream) if closed
                      else NonSeekingReader(stream, record_size_limit=size))
            count = 0
            try:
                for _schema, channel, message in reader.iter_messages(
                        topics=wanted, log_time_order=False):
                    count += 1
                    yield channel, message
            except (McapError, EOFError, struct.error, ValueError) as error:
                if closed:
                    raise RecordingError(f"{path}: not a readable MCAP recording "
                                         f"({' '.join(str(error).split())})") from None
                raise RecordingCutShortError(
                    f"{path} is cut short (the run that wrote it did not close it): "
                    f"{count} of its messages read before the cut") from None
    except OSError as error:
        raise RecordingError(f"{path}: {error.strerror or error}") from error


def _closed(path: Path, stream: io.BufferedReader) -> bool:
    """Whether the file is an MCAP recording that was closed; :class:`RecordingError` if it
    is not an MCAP recording at all."""
    head = stream.read(len(MCAP_MAGIC))
    if not head:
        raise RecordingError(f"{path} is empty: the run recorded nothing")
    if head != MCAP_MAGIC:
        raise RecordingError(f"{path}: not an MCAP recording (it does not begin as one)")
    stream.seek(0, io.SEEK_END)
    closed = stream.tell() >= 2 * len(MCAP_MAGIC)
    if closed:
        stream.seek(-len(MCAP_MAGIC), io.SEEK_END)
        closed = stream.read() == MCAP_MAGIC
    stream.seek(0)
    return closed
