"""PortKeys: ports that remember their blackboard key read and write what py_trees' ports do.

Each check runs the same steps on two behaviours with the same ports and remappings, one with
py_trees' own port methods and one with :class:`PortKeys`, and compares every outcome: the value
read, the error raised (type and message), what the blackboard holds afterwards.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any, ClassVar

import pytest
from py_trees.blackboard import Blackboard, Client
from py_trees.ports import BehaviourWithPorts, NoDataAvailable, PortInformation

from bt_servicesim.behaviours.port_keys import PortKeys
from tests.fakes.leaves import ready

INPUTS: dict[str, PortInformation] = {
    "names": PortInformation(data_type=list[str], required=True),
    "age": PortInformation(data_type=float, required=True),
    "margin": PortInformation(data_type=float, required=False, default_value=0.5),
    "label": PortInformation(data_type=str | None, required=False),
}
OUTPUTS: dict[str, PortInformation] = {
    "count": PortInformation(data_type=int, required=False),
    "seen": PortInformation(data_type=list[str], required=False),
}


class Plain(BehaviourWithPorts, register=False):
    INPUT_PORTS: ClassVar[dict[str, PortInformation]] = INPUTS
    OUTPUT_PORTS: ClassVar[dict[str, PortInformation]] = OUTPUTS


class Keyed(PortKeys, BehaviourWithPorts, register=False):
    INPUT_PORTS: ClassVar[dict[str, PortInformation]] = INPUTS
    OUTPUT_PORTS: ClassVar[dict[str, PortInformation]] = OUTPUTS


REMAPPINGS = {"names": "/rfid/names", "age": "/rfid/age", "margin": "/margin",
              "label": "/label", "count": "/out/count", "seen": "/out/seen"}
Step = Callable[[Any], object]


def outcome(step: Step, behaviour: Any) -> tuple[str, object]:
    try:
        return "value", step(behaviour)
    except Exception as error:  # the error is part of what is compared
        return type(error).__name__, str(error).replace(behaviour.name, "NAME")


def steps() -> Iterator[tuple[str, Step, Callable[[], None]]]:
    """(what, a step on the behaviour, what to do to the blackboard before it)."""
    def put(key: str, value: object) -> Callable[[], None]:
        return lambda: Blackboard.set(key, value)

    def unset(key: str) -> Callable[[], None]:
        return lambda: Blackboard.unset(key) and None

    nothing: Callable[[], None] = lambda: None  # noqa: E731
    yield "missing", lambda b: b.get_input("names"), nothing
    yield "present", lambda b: b.get_input("names"), put("/rfid/names", ["human_1"])
    yield "again", lambda b: b.get_input("names"), put("/rfid/names", ["human_2", "human_3"])
    yield "wrong element", lambda b: b.get_input("names"), put("/rfid/names", ["human", 4])
    yield "None", lambda b: b.get_input("names"), put("/rfid/names", None)
    yield "gone", lambda b: b.get_input("names"), unset("/rfid/names")
    yield "given default", lambda b: b.get_input("names", default=["x"]), nothing
    yield "float", lambda b: b.get_input("age"), put("/rfid/age", 2.5)
    yield "int for float", lambda b: b.get_input("age"), put("/rfid/age", 2)
    yield "port default", lambda b: b.get_input("margin"), nothing
    yield "port default set", lambda b: b.get_input("margin"), put("/margin", 0.25)
    yield "union", lambda b: b.get_input("label"), put("/label", "here")
    yield "union, wrong", lambda b: b.get_input("label"), put("/label", 3.0)
    yield "no such port", lambda b: b.get_input("nothing"), nothing
    yield "write", lambda b: b._set_output("count", 3), nothing
    yield "write again", lambda b: b._set_output("count", 4), nothing
    yield "write wrong type", lambda b: b._set_output("count", "four"), nothing
    yield "write list", lambda b: b._set_output("seen", ["a"]), nothing
    yield "write list, wrong", lambda b: b._set_output("seen", ["a", 1]), nothing
    yield "write no such port", lambda b: b._set_output("nothing", 1), nothing
    yield "write an input", lambda b: b._set_output("names", ["x"]), nothing


def played(cls: type) -> list[tuple[str, tuple[str, object], dict[str, object]]]:
    Blackboard.clear()
    behaviour = ready(cls(name="reader"), **REMAPPINGS)
    seen = []
    for what, step, before in steps():
        before()
        seen.append((what, outcome(step, behaviour), dict(Blackboard.storage)))
    return seen


def test_every_read_and_write_gives_what_py_trees_ports_give() -> None:
    plain, keyed = played(Plain), played(Keyed)
    assert [what for what, _, _ in keyed] == [what for what, _, _ in plain]
    for (what, expected, board), (_, got, keyed_board) in zip(plain, keyed, strict=True):
        assert got == expected, what
        assert keyed_board == board, what
    assert ("NoDataAvailable" in {kind for _, (kind, _), _ in plain}
            and "TypeError" in {kind for _, (kind, _), _ in plain})  # the errors were met


def test_after_the_first_access_ports_go_to_the_storage_directly(
        monkeypatch: pytest.MonkeyPatch) -> None:
    Blackboard.clear()
    behaviour = ready(Keyed(name="reader"), **REMAPPINGS)
    Blackboard.set("/rfid/names", ["human_1"])
    assert behaviour.get_input("names") == ["human_1"]
    behaviour._set_output("count", 1)
    calls: list[str] = []
    for method in ("get", "set", "exists"):
        original = getattr(Client, method)
        monkeypatch.setattr(Client, method, lambda self, *args, _m=method, _o=original, **kw: (
            calls.append(_m), _o(self, *args, **kw))[1])
    Blackboard.set("/rfid/names", ["human_2"])
    assert behaviour.get_input("names") == ["human_2"]
    behaviour._set_output("count", 2)
    assert Blackboard.get("/out/count") == 2
    assert calls == []
    with pytest.raises(NoDataAvailable):  # a missing entry goes the whole way again
        Blackboard.unset("/rfid/names")
        behaviour.get_input("names")
    assert "get" in calls


def test_while_the_activity_stream_records_every_access_is_recorded_as_py_trees_does() -> None:
    streams = {}
    for cls in (Plain, Keyed):
        Blackboard.clear()
        behaviour = ready(cls(name="reader"), **REMAPPINGS)
        Blackboard.set("/rfid/names", ["human_1"])
        behaviour.get_input("names")
        behaviour._set_output("count", 1)
        Blackboard.enable_activity_stream()
        behaviour.get_input("names")
        behaviour._set_output("count", 2)
        assert Blackboard.activity_stream is not None
        streams[cls] = [(item.key, item.activity_type)
                        for item in Blackboard.activity_stream.data]
        Blackboard.disable_activity_stream()
    assert streams[Keyed] == streams[Plain] != []
