"""The lockstep announcement (``servicesim_competition/LockstepPeriod``), serialised by hand,
and the clients' done messages (``LockstepDone``), read by hand.

Design intent: the simulator announces every period, and from one period to the next only
numbers change: the period, its sim time, and the counts. The names (topics and endpoints,
sorted) change only when the node publishes on a topic or answers on an endpoint for the first
time. So the announcement is a CDR template (:class:`~servicesim_sim.wire.cdr.CdrTemplate`) of the
names, laid out again only when their number changes (names are only ever added), and each
period copies it with the numbers packed in. Sorting the names, building an rclpy message of
them and letting ``Publisher.publish`` convert every string again each period cost the loop
about 60 % of its DDS write's own time. ``tests/sim/test_lockstep_message.py`` reads the
bytes back with rclpy and compares them, field for field and in length, with rclpy's own
serialisation.

A done message comes every period from every client; taking it as an rclpy message (rclpy
converts it from C, string by string) cost about three times taking its bytes, and
:class:`DoneReader` reads the few fields the gate needs from those. Bytes in any other
encoding than little-endian CDR are read by rclpy instead.
"""

from __future__ import annotations

import struct
from collections.abc import Collection, Mapping
from typing import NamedTuple

from rclpy.serialization import deserialize_message
from servicesim_competition.msg import LockstepDone

from servicesim_sim.lockstep.gate import Reading
from servicesim_sim.wire.cdr import ENCAPSULATION, CdrTemplate

__all__ = ["AnnouncementBytes", "Done", "DoneReader", "read_done"]

_HEAD = struct.Struct("<QiI")  # period, sim_time (sec, nanosec)
_DONE_HEAD = struct.Struct("<I4xQI")  # client, (padding), period, the endpoints' count
_COUNT = struct.Struct("<I")
_TAIL_AT = 16
"""Where a done's body goes on after its period: its endpoints' count, names, numbers."""


class _Layout:
    """The template for one set of names: where the period and each count go."""

    def __init__(self, topics: list[str], endpoints: list[str]) -> None:
        self.topics, self.endpoints = topics, endpoints
        self.messages = struct.Struct(f"<{len(topics)}Q")
        self.answers = struct.Struct(f"<{len(endpoints)}Q")
        self.zeros = (0,) * len(endpoints)
        """The count of an endpoint nothing was answered on yet, for each."""
        template = CdrTemplate()
        self.head = template.slot(_HEAD, alignment=8)
        template.strings(topics)
        template.count(len(topics))
        self.messages_at = template.slot(self.messages, alignment=8)
        template.strings(endpoints)
        template.count(len(endpoints))
        self.answers_at = template.slot(self.answers, alignment=8)
        self.template = template.done()


class AnnouncementBytes:
    """Encodes announcements; keeps the layout of the names until new names come."""

    def __init__(self) -> None:
        self._layout: _Layout | None = None
        self._sizes: tuple[int, int, int] = (-1, -1, -1)

    def encode(self, *, period: int, sim_time_ns: int, messages: Mapping[str, int],
               served: Collection[str], answers: Mapping[str, int]) -> bytes:
        """The announcement of ``period``: ``messages`` per topic, and ``answers`` per
        endpoint for every endpoint served or answered on (0 where none was sent yet).

        ``messages``, ``served`` and ``answers`` only ever grow (names are never removed), so
        their sizes tell when the names changed.
        """
        layout = self._layout_for(messages, served, answers)
        out = bytearray(layout.template)
        _HEAD.pack_into(out, layout.head, period, *divmod(sim_time_ns, 1_000_000_000))
        layout.messages.pack_into(out, layout.messages_at, *map(messages.__getitem__,
                                                                layout.topics))
        layout.answers.pack_into(out, layout.answers_at, *map(answers.get, layout.endpoints,
                                                              layout.zeros))
        return bytes(out)

    def _layout_for(self, messages: Mapping[str, int], served: Collection[str],
                    answers: Mapping[str, int]) -> _Layout:
        sizes = (len(messages), len(served), len(answers))
        if self._layout is None or sizes != self._sizes:
            self._layout = _Layout(sorted(messages), sorted(set(served) | set(answers)))
            self._sizes = sizes
        return self._layout


class Done(NamedTuple):
    """What a client's done message says (a named tuple: made for every done, and a frozen
    dataclass takes several times as long to make)."""

    client: int
    period: int
    requests: dict[str, int]
    """The requests sent on each endpoint since the client joined (shared between dones:
    never changed)."""
    leaving: bool
    readings: tuple[Reading, ...] = ()
    """The topics the client subscribed to since it joined, each counted from a period."""


class DoneReader:
    """Reads ``LockstepDone`` messages' serialised bytes (by rclpy unless they are in
    little-endian CDR, or not as this reader expects).

    A client names the same endpoints in every done message, so the names read last are
    kept with their bytes: when the next message holds the same bytes in the same place,
    only the numbers around them are read. And most ticks send nothing, so most dones differ
    from the one before in their period alone: when everything after the period is the same
    bytes as last time, the last done's counts and readings are given again (the same
    objects: nobody may change them).
    """

    def __init__(self) -> None:
        self._names: tuple[bytes, list[str], int] = (b"", [], -1)
        """The names' bytes (from the first name's length on), the names, their count."""
        self._last: tuple[bytes, Done | None] = (b"", None)
        """The bytes after the last done's period, and that done."""

    def read(self, data: bytes) -> Done:
        if data[:len(ENCAPSULATION)] == ENCAPSULATION:
            try:
                return self._read_little_endian(data[len(ENCAPSULATION):])
            except (struct.error, IndexError, UnicodeDecodeError):
                pass
        return done_of(deserialize_message(data, LockstepDone))

    def _read_little_endian(self, body: bytes) -> Done:
        """The fields in CDR order; each aligned to its size from the body's start."""
        client, period, count = _DONE_HEAD.unpack_from(body, 0)
        tail, last = self._last
        if last is not None and body[_TAIL_AT:] == tail:
            return Done(client=client, period=period, leaving=last.leaving,
                        requests=last.requests, readings=last.readings)
        done = self._read_counts(body, client, period, count)
        self._last = (body[_TAIL_AT:], done)
        return done

    def _read_counts(self, body: bytes, client: int, period: int, count: int) -> Done:
        """The rest of a done after its head."""
        at = _DONE_HEAD.size
        known, endpoints, known_count = self._names
        if count == known_count and body[at:at + len(known)] == known:
            at += len(known)
        else:
            endpoints, at = _read_names(body, at, count)
            self._names = (bytes(body[_DONE_HEAD.size:at]), endpoints, count)
        at += -at % 4
        (count,) = _COUNT.unpack_from(body, at)
        at += 4
        if count:
            at += -at % 8
        requests = struct.unpack_from(f"<{count}Q", body, at)
        at += 8 * count
        leaving = body[at] != 0
        return Done(client=client, period=period, leaving=leaving,
                    requests=dict(zip(endpoints, requests, strict=False)),
                    readings=_read_readings(body, at + 1))


def _read_names(body: bytes, at: int, count: int) -> tuple[list[str], int]:
    """``count`` strings from ``at`` on; the offset after them."""
    names = []
    for _ in range(count):
        at += -at % 4
        (size,) = _COUNT.unpack_from(body, at)
        if size == 0 or at + 4 + size > len(body):
            raise IndexError("a string beyond the message")
        names.append(str(body[at + 4:at + 3 + size], "utf-8"))
        at += 4 + size
    return names, at


def _read_readings(body: bytes, at: int) -> tuple[Reading, ...]:
    """The readings from ``at`` (just past ``leaving``) on: topics, then their periods."""
    at += -at % 4
    (count,) = _COUNT.unpack_from(body, at)
    if not count:
        return ()
    topics, at = _read_names(body, at + 4, count)
    at += -at % 4
    (starts,) = _COUNT.unpack_from(body, at)
    at += 4
    at += -at % 8
    periods = struct.unpack_from(f"<{starts}Q", body, at)
    if starts != count:
        raise IndexError("readings: as many topics as periods")
    return tuple(Reading(topic=topic, start=start)
                 for topic, start in zip(topics, periods, strict=True))


def read_done(data: bytes) -> Done:
    """One ``LockstepDone`` message's serialised bytes, read (see :class:`DoneReader`)."""
    return DoneReader().read(data)


def done_of(message: LockstepDone) -> Done:
    """A ``LockstepDone`` message, read."""
    return Done(client=int(message.client), period=int(message.period),
                leaving=bool(message.leaving),
                requests=dict(zip(message.endpoints, (int(n) for n in message.requests),
                                  strict=False)),
                readings=tuple(Reading(topic=topic, start=int(start)) for topic, start in zip(
                    message.reading_topics, message.reading_from, strict=False)))
