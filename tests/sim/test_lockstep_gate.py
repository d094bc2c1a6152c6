"""The lockstep gate's rule: when the simulator may step on, and in which order it serves."""

from __future__ import annotations

import random

from servicesim_sim.lockstep.gate import Admission, LockstepGate, Reading, allowed_by

ROOM, PICKUP, CMD_VEL = "/servicesim/room_info", "/servicesim/pickup_guest", "/servicebot/cmd_vel"


def gate_with_client(*endpoints: str) -> tuple[LockstepGate, int]:
    gate = LockstepGate(drop_after_s=10.0)
    gate.endpoints.update(endpoints or (ROOM, PICKUP, CMD_VEL))
    client = gate.join("executive")
    gate.announced(1)
    return gate, client


def admit(gate: LockstepGate, endpoint: str, served: list[str], label: str) -> None:
    number = gate.take(endpoint)
    gate.admit_later(Admission(endpoint=endpoint, number=number,
                               serve=lambda: served.append(label)))


def test_nobody_joined_holds_nothing() -> None:
    gate = LockstepGate()
    gate.announced(1)
    assert not gate.active and gate.is_open()


def test_the_gate_waits_for_the_clients_done_then_for_the_requests_it_counts() -> None:
    gate, client = gate_with_client()
    assert gate.missing() == ["done 1 from executive"]
    gate.done(client, 1, {ROOM: 1})
    assert gate.missing() == [f"1 request(s) on {ROOM}"]
    gate.take(ROOM)
    assert gate.is_open()
    gate.announced(2)
    assert not gate.is_open()  # each period needs its own done


def test_requests_arriving_before_the_done_are_served_in_a_fixed_order() -> None:
    """Arrival order across endpoints does not matter: by endpoint name, then within one."""
    for arrivals in ([ROOM, PICKUP, ROOM], [PICKUP, ROOM, ROOM], [ROOM, ROOM, PICKUP]):
        gate, client = gate_with_client()
        served: list[str] = []
        for index, endpoint in enumerate(arrivals):
            admit(gate, endpoint, served, f"{endpoint}#{arrivals[:index].count(endpoint)}")
        gate.done(client, 1, {ROOM: 2, PICKUP: 1})
        assert gate.is_open()
        for admission in gate.due_admissions():
            admission.serve()
        assert served == [f"{PICKUP}#0", f"{ROOM}#0", f"{ROOM}#1"]


def test_a_request_no_done_has_counted_yet_waits_for_the_period_that_counts_it() -> None:
    gate, client = gate_with_client()
    served: list[str] = []
    admit(gate, ROOM, served, "first")
    admit(gate, ROOM, served, "early")  # sent from a callback after the done went out
    gate.done(client, 1, {ROOM: 1})
    assert [a.serve() for a in gate.due_admissions()] == [None] and served == ["first"]
    gate.announced(2)
    gate.done(client, 2, {ROOM: 2})
    for admission in gate.due_admissions():
        admission.serve()
    assert served == ["first", "early"]


def test_counts_on_endpoints_the_simulator_does_not_serve_are_ignored() -> None:
    gate, client = gate_with_client()
    gate.done(client, 1, {"/bt_servicesim/tree": 3})  # a topic published for someone else
    assert gate.is_open()


def test_a_client_joining_later_only_counts_from_its_join() -> None:
    gate = LockstepGate()
    gate.endpoints.add(ROOM)
    for _ in range(5):
        gate.take(ROOM)  # served before anyone joined
    client = gate.join("late")
    gate.announced(7)
    gate.done(client, 7, {ROOM: 1})
    assert gate.missing() == [f"1 request(s) on {ROOM}"]
    gate.take(ROOM)
    assert gate.is_open()


def test_a_silent_client_is_dropped_after_the_bound_and_the_gate_opens() -> None:
    gate, client = gate_with_client()
    assert gate.drop_silent(100.0) == []  # starts the wait
    assert gate.drop_silent(109.9) == []
    assert not gate.overdue(109.9) and gate.overdue(110.0)
    assert gate.drop_silent(110.0) == ["executive"]
    assert not gate.overdue(200.0)
    assert not gate.active and gate.is_open()
    assert gate.done(client, 1, {}) is False  # a dropped client's late word is ignored


def test_only_the_silent_client_is_dropped_when_another_is_done() -> None:
    gate = LockstepGate(drop_after_s=1.0)
    alive = gate.join("alive")
    gate.join("dead")
    gate.announced(3)
    gate.done(alive, 3, {})
    gate.drop_silent(0.0)
    assert gate.drop_silent(1.0) == ["dead"]
    assert gate.client_names() == ["alive"] and gate.is_open()


def pipelined_gate_with_client() -> tuple[LockstepGate, int]:
    """A gate one period behind its client (the simulator's), the client joined at period 1."""
    gate = LockstepGate(drop_after_s=10.0, lag=1)
    gate.endpoints.update((ROOM, PICKUP, CMD_VEL))
    gate.announced(1)
    client = gate.join("executive")
    return gate, client


def test_a_pipelined_gate_waits_for_the_join_periods_done_then_one_period_behind() -> None:
    gate, client = pipelined_gate_with_client()
    assert gate.missing() == ["done 1 from executive"]  # the join's own period first
    gate.done(client, 1, {})
    assert gate.is_open()
    gate.announced(2)
    assert gate.is_open()  # steps period 3 while the client ticks on 2
    gate.announced(3)
    assert gate.missing() == ["done 2 from executive"]
    gate.done(client, 2, {ROOM: 1})
    assert gate.missing() == [f"1 request(s) on {ROOM}"]


def test_a_client_a_period_ahead_has_its_later_requests_served_a_period_later() -> None:
    """Done 3 arriving while the gate waits on period 2 must not let tick 3's requests in."""
    gate, client = pipelined_gate_with_client()
    gate.done(client, 1, {})
    gate.announced(2)
    gate.announced(3)
    served: list[str] = []
    admit(gate, ROOM, served, "tick 2")
    admit(gate, ROOM, served, "tick 3")
    gate.done(client, 2, {ROOM: 1})
    gate.done(client, 3, {ROOM: 2})  # the client ran on: its tick 3 is done already
    assert gate.is_open()
    for admission in gate.due_admissions():
        admission.serve()
    assert served == ["tick 2"]
    gate.announced(4)
    assert gate.is_open()
    for admission in gate.due_admissions():
        admission.serve()
    assert served == ["tick 2", "tick 3"]


def test_a_silent_client_of_a_pipelined_gate_is_dropped_naming_the_period_awaited() -> None:
    gate, client = pipelined_gate_with_client()
    gate.done(client, 1, {})
    gate.announced(2)
    gate.announced(3)
    assert gate.missing() == ["done 2 from executive"]
    gate.drop_silent(0.0)
    assert gate.drop_silent(10.0) == ["executive"] and gate.is_open()


def test_the_gate_is_open_exactly_when_nothing_is_missing() -> None:
    """is_open() answers without wording what is missing; it must agree with missing()."""
    rng = random.Random(3)
    for _ in range(200):
        gate = LockstepGate(drop_after_s=10.0, lag=rng.choice([0, 0, 1]))
        gate.endpoints.update((ROOM, PICKUP))
        clients: list[int] = []
        for period in range(1, 30):
            gate.announced(period)
            for _ in range(rng.randrange(4)):
                action = rng.randrange(5)
                if action == 0 or not clients:
                    clients.append(gate.join(rng.choice(["executive", "viewer", ""])))
                elif action == 1:
                    gate.done(rng.choice(clients), period - rng.randrange(2),
                              {rng.choice([ROOM, PICKUP, CMD_VEL]): rng.randrange(3)})
                elif action == 2:
                    gate.take(rng.choice([ROOM, PICKUP]))
                elif action == 3:
                    gate.leave(rng.choice(clients))
                assert gate.is_open() == (not gate.missing())
                assert gate.allowed() == allowed_by([  # kept from look to look, never stale
                    (client.baseline, client.requests_by(gate.waits_for(client)))
                    for client in gate._clients.values()])


CAMERA = "/servicebot/camera_front/image_raw"


def test_a_topic_read_after_the_join_is_read_from_the_period_the_client_named() -> None:
    """Tick 2 subscribed to the camera, counting it from period 4; tick 5 unsubscribed."""
    gate, client = pipelined_gate_with_client()
    gate.done(client, 1, {})
    gate.announced(2)
    gate.done(client, 2, {}, (Reading(CAMERA, 4),))
    assert gate.readers_next() == {}  # period 3 is stepped on done 1
    gate.announced(3)
    assert gate.readers_next() == {CAMERA: 1}  # period 4, on done 2
    for period in (3, 4):
        gate.done(client, period, {}, (Reading(CAMERA, 4),))
        gate.announced(period + 1)
        assert gate.readers_next() == {CAMERA: 1}
    gate.done(client, 5, {})  # period 6 was stepped on done 4, read
    gate.announced(6)
    assert gate.readers_next() == {}  # period 7 is stepped on done 5: not read


def test_a_reading_in_a_done_that_came_early_does_not_count_yet() -> None:
    """A client a period ahead: its done 3 names the camera from period 5; period 4 is still
    stepped on done 2, and so is the decision whether to render it."""
    gate, client = pipelined_gate_with_client()
    gate.done(client, 1, {})
    gate.announced(2)
    gate.done(client, 2, {})
    gate.announced(3)
    gate.done(client, 3, {}, (Reading(CAMERA, 5),))  # early: the gate waits on done 2
    assert gate.readers_next() == {}
    gate.announced(4)
    assert gate.readers_next() == {CAMERA: 1}


def test_each_subscription_of_each_client_counts_as_a_reader() -> None:
    gate = LockstepGate(drop_after_s=10.0)
    first, second = gate.join("executive"), gate.join("viewer")
    gate.announced(1)
    gate.done(first, 1, {}, (Reading(CAMERA, 1), Reading(CAMERA, 2)))
    gate.done(second, 1, {}, (Reading(CAMERA, 2), Reading("/servicebot/scan", 3)))
    assert gate.readers_next() == {CAMERA: 3}
