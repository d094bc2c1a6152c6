"""The leaves' lifecycle, as py_trees runs it, without its debug messages when nobody logs.

py_trees' ``Behaviour.tick`` and ``Behaviour.stop`` run a leaf's lifecycle: ``initialise`` when
the leaf was not RUNNING, ``update``, and ``stop`` (``terminate``, then the new status) once it
is no longer RUNNING. On every call they also format a debug message, whether py_trees logs at
debug level or not, and the tick checks the status ``update`` returned against a list of every
status built anew. In a mission tick a dozen leaves tick and about ten stop; the messages (two
statuses formatted as text per stop) and the lists cost about as much as the leaves' own work.

:class:`LeafLifecycle` runs the same steps in the same order, with the same check of the status
(membership among ``Status``'s members, by equality, as py_trees tests it), the same error
message for a status that is none of them, and the same ``iterator`` left behind by a stop;
while py_trees logs at debug level (``py_trees.logging.level``) it hands over to py_trees' own
methods, so the debug lines appear as py_trees writes them.
"""

from __future__ import annotations

from collections.abc import Iterator

import py_trees
from py_trees.common import Status

__all__ = ["LeafLifecycle"]

_STATUSES = tuple(Status)
"""Every status, as py_trees' tick lists them to check what ``update`` returned."""


def _debugging() -> bool:
    """Whether py_trees writes its debug messages (they go through its own methods then)."""
    return py_trees.logging.level < py_trees.logging.Level.INFO


class LeafLifecycle(py_trees.behaviour.Behaviour):
    """py_trees' leaf lifecycle without unread debug messages (see the module docstring).
    Put it before the py_trees class in a leaf's bases."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """py_trees' ``Behaviour.tick``: initialise, update, stop when not RUNNING, yield."""
        if _debugging():
            yield from super().tick()
            return
        if self.status != Status.RUNNING:
            self.initialise()
        new_status = self.update()
        if new_status not in _STATUSES:
            self.logger.error("A behaviour returned an invalid status, setting to INVALID "
                              f"[{new_status}][{self.name}]")
            new_status = Status.INVALID
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def stop(self, new_status: Status) -> None:
        """py_trees' ``Behaviour.stop``: terminate, take the new status, a fresh iterator."""
        if _debugging():
            super().stop(new_status)
            return
        self.terminate(new_status)
        self.status = new_status
        self.iterator = self.tick()
