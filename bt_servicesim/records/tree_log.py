"""A run's tree, tick by tick: the snapshot log (``tree_log.jsonl``), written and read back.

:class:`TreeLog` is a post-tick handler. After every tick it compares each node's status and
feedback message, the tip and the blackboard with what it last wrote, and appends one JSON line
when anything changed. The file stays small and every line is cheap: a line holds only what
changed, so a mission of thousands of ticks is a few megabytes, and the full state at any tick is
the sum of the lines up to it (:class:`TreeHistory` does that sum).

Format, one JSON object per line:

* first line, the tree: ``{"kind": "tree", "version": 1, "tree_file": ..., "phases": ...,
  "nodes": [...]}`` with the :class:`~bt_servicesim.dump.TreeShape` (key, label, kind, memory,
  parent per node); ``phases`` names the composite whose children are the mission's phases
  (``null`` when the run did not say);
* then one line per change: ``{"kind": "tick", "tick": N, "sim_time_s": T, "root": STATUS,
  "tip": KEY or null, "nodes": {KEY: [STATUS, FEEDBACK], ...}, "blackboard": {KEY: REPR, ...}}``.
  ``N`` counts ticks from 1. The first tick line lists every node; later ones only the nodes
  whose status or feedback changed.
  Blackboard values are short reprs; ``null`` means the key was unset. Keys are written as
  :func:`stable_key` makes them: py_trees' ports keep a behaviour's own values (its constants,
  its unwired outputs) under its name *and its random UUID*; the log drops the UUID (the
  qualified name before it is the node's path in the tree, unique already), so two runs of the
  same seed write the same lines.

* last, when the log is closed: ``{"kind": "counts", "nodes": {KEY: [TICKS, STARTS, SUCCESS,
  FAILURE], ...}}`` for every node ever ticked, counted by :class:`TickCounter` as the tree
  ticked (a change log cannot see a node that ran and finished the same way again between two
  lines).

A blackboard value counts as changed when a different object with a different repr is stored
under its key (ports write new values; a value mutated in place is not noticed). Listeners (the
MCAP recorder's tree topic) are called with each :class:`TickRecord` as it is written.
"""

from __future__ import annotations

import bisect
import json
import math
import re
import reprlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from itertools import compress
from json.encoder import encode_basestring
from operator import attrgetter, is_not, itemgetter, ne
from pathlib import Path
from typing import Any, TextIO

import py_trees
from py_trees.common import Status

from bt_servicesim.tree.shape import NodeState, TreeShape, walk

LOG_NAME = "tree_log.jsonl"
FORMAT_VERSION = 1
LINES_PER_WRITE = 20
"""Lines kept before they are written, whole, in one write (2 sim s of ticks at most): a write
and a flush per tick cost more than the line. A run that ends, Ctrl-C included, writes them
all; one killed outright loses at most these, and never leaves half a line."""
_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 120
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxdict = _SHORT.maxset = 6
_UUID_SUFFIX = re.compile(
    r"_[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}(?=/|$)", re.IGNORECASE)
_STATE_NAMES = ("status", "feedback_message")
_STATE = attrgetter(*_STATE_NAMES)
"""A behaviour's :data:`~bt_servicesim.tree.shape.NodeState`."""
_STATE_ITEMS = itemgetter(*_STATE_NAMES)
"""The same, from the behaviour's ``__dict__`` (see :func:`state_reader`)."""


class TreeLogError(ValueError):
    """A snapshot log that cannot be read; the message is one line naming file and problem."""


@dataclass(frozen=True)
class TickRecord:
    """What changed at one tick (see the module docstring for the JSON form)."""

    tick: int
    sim_time_s: float
    root: Status
    tip: str | None
    nodes: dict[str, NodeState]
    blackboard: dict[str, str | None]

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": "tick", "tick": self.tick, "sim_time_s": round(self.sim_time_s, 3),
            "root": self.root.name, "tip": self.tip,
            "nodes": {key: [status.name, feedback]
                      for key, (status, feedback) in self.nodes.items()},
            "blackboard": self.blackboard,
        }

    @classmethod
    def from_json(cls, line: dict[str, Any]) -> TickRecord:
        return cls(
            tick=int(line["tick"]), sim_time_s=float(line["sim_time_s"]),
            root=Status[line["root"]], tip=line["tip"],
            nodes={key: (Status[status], str(feedback))
                   for key, (status, feedback) in line["nodes"].items()},
            blackboard=dict(line.get("blackboard", {})),
        )


def state_reader(behaviours: Sequence[py_trees.behaviour.Behaviour],
                 ) -> Callable[[], list[NodeState]]:
    """What reads every behaviour's status and feedback, in order, at every tick.

    Attribute access looks at each behaviour's class before its ``__dict__``; read straight
    from the dicts, the same values cost about half as much, and the log reads them for every
    node after every tick. The dicts hold what attribute access gives when each behaviour keeps
    both in its ``__dict__`` and its class puts nothing in between (no ``__getattribute__`` of
    its own, no data descriptor of either name): so it is read from the dicts when every
    behaviour is such, and through attribute access otherwise.
    """
    if all(map(_kept_plainly, behaviours)):
        dicts = [behaviour.__dict__ for behaviour in behaviours]
        return lambda: list(map(_STATE_ITEMS, dicts))
    return lambda: list(map(_STATE, behaviours))


def _kept_plainly(behaviour: object) -> bool:
    """Whether the behaviour's ``__dict__`` holds its status and feedback as they read."""
    cls = type(behaviour)
    if cls.__getattribute__ is not object.__getattribute__:
        return False
    for name in _STATE_NAMES:
        if name not in getattr(behaviour, "__dict__", {}):
            return False
        for klass in cls.__mro__:
            found = klass.__dict__.get(name)
            if found is not None and (hasattr(type(found), "__set__")
                                      or hasattr(type(found), "__delete__")):
                return False
    return True


def short_repr(value: object) -> str:
    """A blackboard value as one short line."""
    return " ".join(_SHORT.repr(value).split())


def stable_key(key: str) -> str:
    """A blackboard key without the random UUID py_trees' ports put after a node's name."""
    return _UUID_SUFFIX.sub("", key)


def blackboard_values() -> dict[str, object]:
    return dict(py_trees.blackboard.Blackboard.storage)


_RUNNING, _SUCCESS, _FAILURE = Status.RUNNING, Status.SUCCESS, Status.FAILURE


class TickCounter(py_trees.visitors.VisitorBase):
    """A visitor that counts, per node, its ticks, starts and outcomes as the tree ticks.

    py_trees hands a visitor every behaviour it ticks, just after its tick, however often a
    tick reaches it. A tick is a start when the node was not RUNNING before it (its status at
    its last visit, or as the log last saw it: a node stopped from above, never visited, is
    INVALID). This runs for every node ticked, so it does as little as it can: one dict look-up
    by the behaviour itself and a few list operations.
    """

    def __init__(self, behaviours: list[py_trees.behaviour.Behaviour]) -> None:
        super().__init__(full=False)
        self._behaviours = behaviours
        self._tallies: dict[py_trees.behaviour.Behaviour, list[Any]] = {
            behaviour: [0, 0, 0, 0, behaviour.status] for behaviour in behaviours}
        """Per behaviour: ticks, starts, successes, failures, and its status when last seen."""

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        tally = self._tallies.get(behaviour)
        if tally is None:
            return
        status = behaviour.status
        tally[0] += 1
        if tally[4] is not _RUNNING:
            tally[1] += 1
        if status is _SUCCESS:
            tally[2] += 1
        elif status is _FAILURE:
            tally[3] += 1
        tally[4] = status

    def saw(self, index: int, status: Status) -> None:
        """The log saw node ``index`` (in :func:`walk` order) end a tick with ``status``."""
        self._tallies[self._behaviours[index]][4] = status

    @property
    def counts(self) -> list[list[int]]:
        """Ticks, starts, successes and failures per node, in :func:`walk` order."""
        return [self._tallies[behaviour][:4] for behaviour in self._behaviours]


class TreeLog:
    """Post-tick handler that appends a line to ``path`` whenever the tree changed.

    Args:
        tree: the tree being ticked; register with ``tree.add_post_tick_handler(log)``
        path: the ``tree_log.jsonl`` to write (truncated)
        sim_time_s: reads the sim time, in seconds, at the end of a tick
        tree_file: the tree file the run loaded, noted in the header
        blackboard: reads the blackboard's current values (default: py_trees' global storage)
        phases: the composite whose children are the mission's phases, noted in the header
        count: count every node's ticks, starts and outcomes (:class:`TickCounter`) and write
            them as the last line
    """

    def __init__(self, *, tree: py_trees.trees.BehaviourTree, path: Path,
                 sim_time_s: Callable[[], float], tree_file: str | None = None,
                 blackboard: Callable[[], dict[str, object]] = blackboard_values,
                 phases: str | None = None, count: bool = True) -> None:
        self.tree = tree
        self.shape = TreeShape.of(tree.root)
        self.path = path
        self.listeners: list[Callable[[TickRecord], None]] = []
        self._sim_time_s = sim_time_s
        self._blackboard = blackboard
        self._behaviours = walk(tree.root)
        self._read_states = state_reader(self._behaviours)
        self._keys = self.shape.keys
        self._key_of = {id(behaviour): key
                        for key, behaviour in zip(self._keys, self._behaviours, strict=True)}
        self._last_states: Sequence[NodeState | None] = [None] * len(self._behaviours)
        self._last_keys: list[str] = []
        self._last_objects: list[object] = []
        self._last_nodes: dict[str, NodeState] = {}
        self._last_tip: str | None = None
        self._last_values: dict[str, tuple[object, str]] = {}
        self._stable_keys: dict[str, str] = {}
        self._records = 0
        self.counter = TickCounter(self._behaviours)
        if count:
            tree.add_visitor(self.counter)
        self._count = count
        self._line = TickLine()
        self._unwritten: list[str] = []
        self._stream: TextIO | None = path.open("w", encoding="utf-8")
        header = {"kind": "tree", "version": FORMAT_VERSION, "tree_file": tree_file,
                  "phases": phases, "nodes": self.shape.to_json()}
        self._write(header)
        self._write_out()

    @property
    def records(self) -> int:
        """How many tick lines were written."""
        return self._records

    @property
    def latest(self) -> tuple[dict[str, NodeState], str | None]:
        """Every node's state and the tip as of the last record (an interrupt does not count)."""
        return dict(self._last_nodes), self._last_tip

    def __call__(self, tree: py_trees.trees.BehaviourTree) -> None:
        """The post-tick handler: log this tick if anything changed."""
        self.log(tick=tree.count + 1)  # py_trees counts after the handlers

    def log(self, *, tick: int) -> None:
        """Log tick number ``tick`` if anything changed; the tree must not have ticked since."""
        record = self.capture(tick=tick)
        if record is None:
            return
        self._write_text(self._line.of(record))
        self._records += 1
        for listener in self.listeners:
            listener(record)

    def capture(self, *, tick: int) -> TickRecord | None:
        """What changed since the last record, or ``None`` when nothing did.

        Runs after every tick, so the node by node comparison against the states last written
        is made by the interpreter's built-ins (``map``, ``compress``) rather than a Python
        loop over the whole tree: a tick changes a few of the tree's hundred and more nodes.
        """
        states: list[NodeState] = self._read_states()
        changed_at = list(compress(range(len(states)), map(ne, states, self._last_states)))
        tip = self._tip_key()
        values = self._blackboard_changes()
        if not changed_at and not values and tip == self._last_tip:
            return None
        changed: dict[str, NodeState] = {}
        saw = self.counter.saw
        for index in changed_at:
            key, state = self._keys[index], states[index]
            self._last_nodes[key] = changed[key] = state
            saw(index, state[0])
        self._last_states = states
        self._last_tip = tip
        return TickRecord(tick=tick, sim_time_s=self._sim_time_s(), root=self.tree.root.status,
                          tip=tip, nodes=changed, blackboard=values)

    def _tip_key(self) -> str | None:
        tip = self.tree.root.tip()
        return None if tip is None else self._key_of.get(id(tip))

    def _blackboard_changes(self) -> dict[str, str | None]:
        """The keys whose value is another object with another repr, or that went.

        Keys rarely come or go, so while they stay as they were the values are compared by
        identity with built-ins, and only the keys that hold another object are looked at.
        """
        current = self._blackboard()
        keys, values = list(current), list(current.values())
        moved: Iterator[str]
        if keys == self._last_keys:
            moved = compress(keys, map(is_not, values, self._last_objects))
        else:
            moved = iter(keys)
        changes: dict[str, str | None] = {}
        for key in moved:
            value = current[key]
            last = self._last_values.get(key)
            if last is not None and last[0] is value:
                continue
            text = short_repr(value)
            self._last_values[key] = (value, text)
            if last is None or last[1] != text:
                changes[self._stable(key)] = text
        if keys != self._last_keys:
            for key in [key for key in self._last_values if key not in current]:
                del self._last_values[key]
                changes[self._stable(key)] = None
        self._last_keys, self._last_objects = keys, values
        return changes

    def _stable(self, key: str) -> str:
        """:func:`stable_key`, remembered: a key is written again and again."""
        stable = self._stable_keys.get(key)
        if stable is None:
            stable = self._stable_keys[key] = stable_key(key)
        return stable

    def _write(self, line: dict[str, Any]) -> None:
        self._write_text(json.dumps(line, ensure_ascii=False) + "\n")

    def _write_text(self, text: str) -> None:
        """Keep a line; write the lines kept once there are :data:`LINES_PER_WRITE`."""
        if self._stream is None:
            return
        self._unwritten.append(text)
        if len(self._unwritten) >= LINES_PER_WRITE:
            self._write_out()

    def _write_out(self) -> None:
        """Write the lines kept, whole, in one write."""
        if self._stream is not None and self._unwritten:
            self._stream.write("".join(self._unwritten))
            self._stream.flush()
            self._unwritten.clear()

    def close(self) -> None:
        """Write the lines kept and the counts line, and close the file (once)."""
        if self._stream is not None and self._count:
            self._write({"kind": "counts", "nodes": {
                key: counts for key, counts in zip(self._keys, self.counter.counts, strict=True)
                if counts[0]}})
        if self._stream is not None:
            self._write_out()
            self._stream.close()
            self._stream = None


class TickLine:
    """A tick record's line, the text ``json.dumps(record.to_json(), ensure_ascii=False)``
    gives, built without the dicts: the keys, which are long tree paths and blackboard names
    written again and again, are encoded once each."""

    def __init__(self) -> None:
        self._keys: dict[str, str] = {}

    def of(self, record: TickRecord) -> str:
        key, text = self._key, _string
        nodes = ", ".join([f'{key(name)}["{status.name}", {text(feedback)}]'
                           for name, (status, feedback) in record.nodes.items()])
        values = ", ".join([f"{key(name)}{'null' if value is None else text(value)}"
                            for name, value in record.blackboard.items()])
        tip = "null" if record.tip is None else text(record.tip)
        return (f'{{"kind": "tick", "tick": {record.tick}, '
                f'"sim_time_s": {_number(round(record.sim_time_s, 3))}, '
                f'"root": "{record.root.name}", "tip": {tip}, "nodes": {{{nodes}}}, '
                f'"blackboard": {{{values}}}}}\n')

    def _key(self, name: str) -> str:
        """``"name": `` as JSON, remembered."""
        text = self._keys.get(name)
        if text is None:
            text = self._keys[name] = f"{_string(name)}: "
        return text


def _string(value: object) -> str:
    """A string as JSON writes it (anything else, too, as ``json.dumps`` would)."""
    return encode_basestring(value) if type(value) is str else json.dumps(
        value, ensure_ascii=False)


def _number(value: float) -> str:
    """A number as JSON writes it."""
    return repr(value) if math.isfinite(value) else json.dumps(value)


# ------------------------------------------------------------------------------------ reading
@dataclass
class TreeState:
    """The whole tree as logged at one tick: every node's status and feedback, the tip."""

    tick: int = 0
    sim_time_s: float = 0.0
    root: Status = Status.INVALID
    tip: str | None = None
    nodes: dict[str, NodeState] = field(default_factory=dict)
    blackboard: dict[str, str] = field(default_factory=dict)

    def apply(self, record: TickRecord) -> TreeState:
        """The state after ``record`` (a new object; this one is unchanged)."""
        state = TreeState(tick=self.tick, sim_time_s=self.sim_time_s, root=self.root,
                          tip=self.tip, nodes=dict(self.nodes), blackboard=dict(self.blackboard))
        state.advance(record)
        return state

    def advance(self, record: TickRecord) -> None:
        """Become the state after ``record``, in place: for a reader that keeps only the latest
        state, a copy of the whole tree at every tick is work for nothing."""
        self.tick, self.sim_time_s, self.root, self.tip = (
            record.tick, record.sim_time_s, record.root, record.tip)
        self.nodes.update(record.nodes)
        for key, text in record.blackboard.items():
            if text is None:
                self.blackboard.pop(key, None)
            else:
                self.blackboard[key] = text


@dataclass(frozen=True)
class TreeHistory:
    """A snapshot log read back: the tree's shape and its state after every logged change."""

    shape: TreeShape
    tree_file: str | None
    states: tuple[TreeState, ...]
    phases: str | None = None

    def at_tick(self, tick: int) -> TreeState:
        """The state as it was at ``tick`` (the last change at or before it)."""
        return self.states[self.index_at_tick(tick)]

    def at_time(self, sim_time_s: float) -> TreeState:
        """The state as it was at ``sim_time_s`` sim seconds."""
        return self.states[self.index_at_time(sim_time_s)]

    def index_at_tick(self, tick: int) -> int:
        ticks = [state.tick for state in self.states]
        return self._checked(bisect.bisect_right(ticks, tick) - 1, f"tick {tick}")

    def index_at_time(self, sim_time_s: float) -> int:
        times = [state.sim_time_s for state in self.states]
        return self._checked(bisect.bisect_right(times, sim_time_s) - 1,
                             f"sim time {sim_time_s:g} s")

    def _checked(self, position: int, when: str) -> int:
        if not self.states:
            raise TreeLogError("the log has no ticks: the tree never ticked")
        if position < 0:
            first = self.states[0]
            raise TreeLogError(f"nothing logged at {when}: the first record is tick "
                               f"{first.tick} at {first.sim_time_s:.1f} s sim")
        return position

    def check_within(self, *, tick: int | None = None, sim_time_s: float | None = None) -> None:
        """:class:`TreeLogError` for a moment after the log's last record: the run had ended
        (its last tick changed something: the root's status, at least) and nothing was
        logged then, so no state can be shown for it."""
        if not self.states:
            return
        last = self.states[-1]
        if tick is not None and tick > last.tick:
            when = f"tick {tick}"
        elif sim_time_s is not None and sim_time_s > last.sim_time_s:
            when = f"sim time {sim_time_s:g} s"
        else:
            return
        raise TreeLogError(f"nothing logged at {when}: the run's last record is tick "
                           f"{last.tick} at {last.sim_time_s:.1f} s sim")


def read_tree_log(path: Path) -> TreeHistory:
    """Read ``tree_log.jsonl``; every problem is a :class:`TreeLogError` naming the file."""
    try:
        with path.open(encoding="utf-8") as stream:
            return _read(stream)
    except OSError as error:
        raise TreeLogError(f"{path}: {error.strerror or error}") from error
    except (ValueError, KeyError, TypeError) as error:
        raise TreeLogError(f"{path}: {error}") from error


def _read(stream: TextIO) -> TreeHistory:
    header, records = _header_and_records(stream)
    states: list[TreeState] = []
    state = TreeState()
    for record in records:
        state = state.apply(record)
        states.append(state)
    return TreeHistory(shape=header.shape, tree_file=header.tree_file, states=tuple(states),
                       phases=header.phases)


@dataclass
class LogHeader:
    """The log's first line: the tree's shape, its file and its phases' composite; and, once
    the records have been read, the counts line (None in a log cut short)."""

    shape: TreeShape
    tree_file: str | None
    phases: str | None
    counts: dict[str, list[int]] | None = None


def read_records(path: Path) -> tuple[LogHeader, list[TickRecord]]:
    """The header and every tick record, as written (no state is summed up); every problem is
    a :class:`TreeLogError` naming the file."""
    try:
        with path.open(encoding="utf-8") as stream:
            header, records = _header_and_records(stream)
            return header, list(records)
    except OSError as error:
        raise TreeLogError(f"{path}: {error.strerror or error}") from error
    except (ValueError, KeyError, TypeError) as error:
        raise TreeLogError(f"{path}: {error}") from error


def _header_and_records(stream: TextIO) -> tuple[LogHeader, Iterator[TickRecord]]:
    lines = _json_lines(stream)
    _, header = next(lines, (0, None))
    if header is None or header.get("kind") != "tree":
        raise ValueError("not a tree snapshot log (the first line must describe the tree)")
    if header.get("version") != FORMAT_VERSION:
        raise ValueError(f"log format version {header.get('version')}, "
                         f"this reader knows {FORMAT_VERSION}")
    shape = TreeShape.from_json(header["nodes"])

    def records() -> Iterator[TickRecord]:
        for number, line in lines:
            if line.get("kind") == "counts":
                read.counts = {str(key): [int(count) for count in counts]
                               for key, counts in line.get("nodes", {}).items()}
                continue
            try:
                yield TickRecord.from_json(line)
            except (KeyError, TypeError, ValueError) as error:
                raise ValueError(f"line {number}: malformed tick record ({error!r})") from error

    phases = header.get("phases")
    read = LogHeader(shape=shape, tree_file=header.get("tree_file"),
                     phases=None if phases is None else str(phases))
    return read, records()


def _json_lines(stream: TextIO) -> Iterator[tuple[int, dict[str, Any]]]:
    for number, text in enumerate(stream, start=1):
        if not text.strip():
            continue
        try:
            line = json.loads(text)
        except json.JSONDecodeError as error:
            raise ValueError(f"line {number}: not JSON ({error.msg})") from error
        if not isinstance(line, dict):
            raise ValueError(f"line {number}: not a JSON object")
        yield number, line


def behaviour_tree_of(executive: object) -> py_trees.trees.BehaviourTree | None:
    """The executive's py_trees tree, or ``None`` for an executive that is not a tree."""
    tree = getattr(executive, "tree", None)
    return tree if isinstance(tree, py_trees.trees.BehaviourTree) else None
