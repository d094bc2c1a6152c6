"""Ports that find their blackboard entry once: py_trees' port reads and writes, made cheap.

py_trees' ``PortsMixin.get_input`` and ``_set_output`` resolve a port's blackboard key anew on
every call: the port is looked up, the client's namespace joined to the name, its permissions
checked and its remapping applied, through three layers of blackboard client methods. The
mission tree's leaves read and write a dozen ports every tick, which made port access one of
the tick's largest costs. The key a port maps to cannot change once the behaviour's client has
registered it, so :class:`PortKeys` remembers it after the first read or write that py_trees
itself carried out, and from then on reads and writes ``Blackboard.storage`` under it directly.

Whatever py_trees would do differently goes through py_trees: a port not yet used, an entry
that is missing or ``None`` (py_trees raises, or falls back to a default), a value of the wrong
type (py_trees raises ``TypeError``), and every access while the blackboard's activity stream
records (py_trees records it). A value is checked against the port's type exactly as py_trees
checks it (``is_instance_of_type``), so what a behaviour reads or writes, and every error, are
what py_trees' own methods give.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any, get_origin

from py_trees.blackboard import Blackboard
from py_trees.ports import PortsMixin
from py_trees.ports_utils import is_instance_of_type

__all__ = ["PortKeys"]

TypeCheck = Callable[[Any], bool]


class PortKeys(PortsMixin, register=False):
    """:class:`~py_trees.ports.PortsMixin` with each port's blackboard key remembered (see the
    module docstring). Put it before the py_trees class in a behaviour's bases."""

    def get_input(self, port_name: str, default: Any = None) -> Any:
        """py_trees' ``get_input``, through the remembered key once the port has been read."""
        remembered = _remembered(self, "_input_keys")
        found = remembered.get(port_name)
        if found is not None and Blackboard.activity_stream is None:
            key, fits = found
            value = Blackboard.storage.get(key)
            if value is not None and fits(value):
                return value
        value = super().get_input(port_name, default)
        if found is None and self.blackboard_client.exists(port_name):
            remembered[port_name] = (self._key_of(port_name),
                                     _type_check(self.input_ports()[port_name].data_type))
        return value

    def _set_output(self, port_name: str, value: Any) -> None:
        """py_trees' ``_set_output``, through the remembered key once the port was written."""
        remembered = _remembered(self, "_output_keys")
        found = remembered.get(port_name)
        if found is not None and Blackboard.activity_stream is None:
            key, fits = found
            if fits(value):
                Blackboard.storage[key] = value
                return
        super()._set_output(port_name, value)
        if found is None:
            remembered[port_name] = (self._key_of(port_name),
                                     _type_check(self.output_ports()[port_name].data_type))

    def _key_of(self, port_name: str) -> str:
        """The storage key the client's own accessors read and write for ``port_name``."""
        client = self.blackboard_client
        remappings: dict[str, str] = client.remappings
        return remappings[Blackboard.absolute_name(client.namespace, port_name)]


def _remembered(behaviour: PortKeys, name: str) -> dict[str, tuple[str, TypeCheck]]:
    """The behaviour's remembered keys of one direction (made on first use, so that the
    behaviour's own ``__init__`` needs no part in it)."""
    keys: dict[str, tuple[str, TypeCheck]] | None = behaviour.__dict__.get(name)
    if keys is None:
        keys = behaviour.__dict__[name] = {}
    return keys


def _type_check(data_type: Any) -> TypeCheck:
    """``is_instance_of_type`` for one port's type; a plain ``isinstance`` for a plain class,
    which is what it comes to there."""
    if get_origin(data_type) is None and isinstance(data_type, type):
        return partial(_is_a, data_type)
    return partial(_fits, data_type)


def _is_a(data_type: type, value: Any) -> bool:
    return isinstance(value, data_type)


def _fits(data_type: Any, value: Any) -> bool:
    return is_instance_of_type(value, data_type)
