"""The people's messages, serialised by hand: ``servicesim_competition/ActorStates`` (everyone,
every 0.5 sim s) and ``ActorNames`` (the RFID reading, every 0.1 sim s while someone is near).

Design intent: the people and their names do not change during an episode, only where they
stand and who is near. Building an ``ActorStates`` made a ``Point`` per person and let
``Publisher.publish`` convert every name and role again; here the names and roles are laid out
once in a CDR template (:class:`~servicesim_sim.wire.cdr.CdrTemplate`, laid out again if they
change) and each message packs the positions in, and an RFID reading's bytes are kept per set
of names near (a robot passing someone reads the same names for seconds).
``tests/sim/test_actor_messages.py`` reads both back with rclpy and compares them, field for
field and in length, with rclpy's own serialisation.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

from servicesim_sim.wire.cdr import STAMP, CdrTemplate

__all__ = ["ActorNamesBytes", "ActorStatesBytes"]

_LENGTH = struct.Struct("<I")
NAMES_KEPT = 64
"""RFID readings kept serialised; beyond that the oldest are forgotten (a bound, not a need:
the people near the robot come in a few dozen sets a run)."""


class _StatesLayout:
    """The template for one set of people: where the stamp and the positions go."""

    def __init__(self, names: tuple[str, ...], roles: tuple[str, ...]) -> None:
        self.key = (names, roles)
        self.positions = struct.Struct(f"<{3 * len(names)}d")
        template = CdrTemplate()
        self.stamp = template.slot(STAMP, alignment=4)
        template.strings(list(names))
        template.strings(list(roles))
        template.count(len(names))
        self.positions_at = template.slot(self.positions, alignment=8)
        self.template = template.done()


class ActorStatesBytes:
    """Encodes ``ActorStates``; keeps the layout of the people until they change."""

    def __init__(self) -> None:
        self._layout: _StatesLayout | None = None

    def encode(self, *, stamp: tuple[int, int],
               people: Sequence[tuple[str, str, float, float]], guest_state: str) -> bytes:
        """``people``: (name, role, x, y) of everyone, in the message's order."""
        key = (tuple(person[0] for person in people), tuple(person[1] for person in people))
        layout = self._layout
        if layout is None or layout.key != key:
            layout = self._layout = _StatesLayout(*key)
        out = bytearray(layout.template)
        STAMP.pack_into(out, layout.stamp, *stamp)
        numbers = [0.0] * (3 * len(people))
        numbers[0::3] = [float(person[2]) for person in people]
        numbers[1::3] = [float(person[3]) for person in people]
        layout.positions.pack_into(out, layout.positions_at, *numbers)
        encoded = guest_state.encode() + b"\x00"  # the template ends 4-aligned
        out += _LENGTH.pack(len(encoded)) + encoded
        return bytes(out)


class ActorNamesBytes:
    """Encodes ``ActorNames``, keeping the bytes of the last :data:`NAMES_KEPT` readings."""

    def __init__(self) -> None:
        self._kept: dict[tuple[str, ...], bytes] = {}

    def encode(self, names: Sequence[str]) -> bytes:
        key = tuple(names)
        encoded = self._kept.get(key)
        if encoded is None:
            template = CdrTemplate()
            template.strings(list(key))
            encoded = template.done()
            if len(self._kept) >= NAMES_KEPT:
                del self._kept[next(iter(self._kept))]
            self._kept[key] = encoded
        return encoded
