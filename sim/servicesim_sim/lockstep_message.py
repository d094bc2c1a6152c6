"""The lockstep announcement (``servicesim_competition/LockstepPeriod``), serialised by hand.

Design intent: the simulator announces every period, and from one period to the next only
numbers change: the period, its sim time, and the counts. The names (topics and endpoints,
sorted) change only when the node publishes on a topic or answers on an endpoint for the first
time. So the announcement is a CDR template (:class:`~servicesim_sim.cdr.CdrTemplate`) of the
names, laid out again only when their number changes (names are only ever added), and each
period copies it with the numbers packed in. Sorting the names, building an rclpy message of
them and letting ``Publisher.publish`` convert every string again each period cost the loop
about 60 % of its DDS write's own time. ``tests/sim/test_lockstep_message.py`` reads the bytes back with
rclpy and compares them, field for field and in length, with rclpy's own serialisation.
"""

from __future__ import annotations

import struct
from collections.abc import Collection, Mapping

from servicesim_sim.cdr import CdrTemplate

__all__ = ["AnnouncementBytes"]

_HEAD = struct.Struct("<QiI")  # period, sim_time (sec, nanosec)


class _Layout:
    """The template for one set of names: where the period and each count go."""

    def __init__(self, topics: list[str], endpoints: list[str]) -> None:
        self.topics, self.endpoints = topics, endpoints
        self.messages = struct.Struct(f"<{len(topics)}Q")
        self.answers = struct.Struct(f"<{len(endpoints)}Q")
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
        layout.messages.pack_into(out, layout.messages_at,
                                  *[messages[topic] for topic in layout.topics])
        layout.answers.pack_into(out, layout.answers_at,
                                 *[answers.get(endpoint, 0) for endpoint in layout.endpoints])
        return bytes(out)

    def _layout_for(self, messages: Mapping[str, int], served: Collection[str],
                    answers: Mapping[str, int]) -> _Layout:
        sizes = (len(messages), len(served), len(answers))
        if self._layout is None or sizes != self._sizes:
            self._layout = _Layout(sorted(messages), sorted(set(served) | set(answers)))
            self._sizes = sizes
        return self._layout
