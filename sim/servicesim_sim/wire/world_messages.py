"""The world's state messages, serialised by hand: where everyone is (``ActorStates``) and the
referee's books (``RefereeState``), both every 0.5 sim s and recorded by every run.

Design intent: as for the pose messages (:mod:`servicesim_sim.wire.pose_messages`), their
layout is fixed once their strings are: the people's names and roles, and the checkpoints'
names, never change within an episode. So each is a template of CDR bytes
(:class:`~servicesim_sim.wire.cdr.CdrTemplate`) with the numbers packed into their slots;
only the guest's state, the one string that changes, is appended (from a table of the few it
takes). Building an ``ActorStates`` of the office's 41 people as an rclpy message and letting
``Publisher.publish`` convert it cost about 80 µs; ``tests/sim/test_world_messages.py`` reads
these bytes back with rclpy and compares them, field for field and in length, with rclpy's
own serialisation.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

from servicesim_sim.wire.cdr import STAMP, CdrTemplate

__all__ = ["ActorStatesBytes", "RefereeStateBytes"]

_FLAGS = struct.Struct("<??")
_TWO_FLOATS = struct.Struct("<2d")
_COUNTS = struct.Struct("<4I")


class ActorStatesBytes:
    """``servicesim_competition/ActorStates`` of the people ``names`` with ``roles``, in that
    order; :meth:`encode` takes their places in the same order."""

    def __init__(self, *, names: Sequence[str], roles: Sequence[str]) -> None:
        if len(names) != len(roles):
            raise ValueError(f"{len(names)} names but {len(roles)} roles")
        template = CdrTemplate()
        self._stamp = template.slot(STAMP, alignment=4)
        template.strings(list(names))
        template.strings(list(roles))
        template.count(len(names))
        self._positions = struct.Struct(f"<{3 * len(names)}d")
        self._positions_at = template.slot(self._positions, alignment=8)
        self._template = template.done()
        self._guest_states: dict[str, bytes] = {}

    def encode(self, *, stamp: tuple[int, int], positions: Sequence[tuple[float, float]],
               guest_state: str) -> bytes:
        """The message at ``stamp`` (sec, nanosec), everyone at ``positions`` (x, y; z 0)."""
        out = bytearray(self._template)
        STAMP.pack_into(out, self._stamp, *stamp)
        self._positions.pack_into(out, self._positions_at,
                                  *(value for x, y in positions
                                    for value in (float(x), float(y), 0.0)))
        return bytes(out) + self._guest_state(guest_state)

    def _guest_state(self, state: str) -> bytes:
        """The trailing string's bytes (the positions before it end 8-aligned: no padding)."""
        encoded = self._guest_states.get(state)
        if encoded is None:
            text = state.encode() + b"\x00"
            encoded = self._guest_states[state] = struct.pack("<I", len(text)) + text
        return encoded


class RefereeStateBytes:
    """``servicesim_competition/RefereeState`` of a task whose checkpoints are ``names``."""

    def __init__(self, *, names: Sequence[str]) -> None:
        template = CdrTemplate()
        self._stamp = template.slot(STAMP, alignment=4)
        self._flags = template.slot(_FLAGS, alignment=1)
        self._score_and_time = template.slot(_TWO_FLOATS, alignment=8)
        template.strings(list(names))
        template.count(len(names))
        self._done = struct.Struct(f"<{len(names)}?")
        self._done_at = template.slot(self._done, alignment=1)
        template.count(len(names))
        self._times = struct.Struct(f"<{len(names)}d")
        self._times_at = template.slot(self._times, alignment=8)
        self._counts = template.slot(_COUNTS, alignment=4)
        self._penalties = template.slot(_TWO_FLOATS, alignment=8)
        self._template = template.done()

    def encode(self, *, stamp: tuple[int, int], running: bool, completed: bool, score: float,
               task_sim_time: float, done: Sequence[bool], times: Sequence[float],
               counts: tuple[int, int, int, int], contact: float,
               approximation: float) -> bytes:
        """The books at ``stamp`` (sec, nanosec); ``counts``: failed pick-ups, failed
        drop-offs, too fast, drifts."""
        out = bytearray(self._template)
        STAMP.pack_into(out, self._stamp, *stamp)
        _FLAGS.pack_into(out, self._flags, running, completed)
        _TWO_FLOATS.pack_into(out, self._score_and_time, score, task_sim_time)
        self._done.pack_into(out, self._done_at, *done)
        self._times.pack_into(out, self._times_at, *times)
        _COUNTS.pack_into(out, self._counts, *counts)
        _TWO_FLOATS.pack_into(out, self._penalties, contact, approximation)
        return bytes(out)
