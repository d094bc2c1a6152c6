"""Stop signals while the node spins: raised between two turns of the executor, never inside a
callback, and a second one at once; a stop signal the process was started with ignored stays
ignored, and the children the project stops itself get them back."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from std_msgs.msg import Empty

from bt_servicesim.mission.stopping import (
    BetweenSpins,
    StopSignals,
    Terminated,
    parent_death_signal,
)


class _Executor:
    """One turn runs ``callback``, as an executor runs a callback that has work."""

    def __init__(self, callback: Callable[[], None]) -> None:
        self.callback = callback
        self.turns = 0

    def spin_once(self, timeout_sec: float | None = None) -> None:
        self.turns += 1
        self.callback()


def _signal_then_work(number: int, done: list[str]) -> Callable[[], None]:
    def callback() -> None:
        os.kill(os.getpid(), number)
        sum(range(10_000))  # Python runs on after the signal: its handler runs here
        done.append("callback finished")

    return callback


@pytest.mark.parametrize(("number", "raised"), [(signal.SIGINT, KeyboardInterrupt),
                                                (signal.SIGTERM, Terminated)])
def test_a_deferred_signal_lets_the_callback_finish_and_comes_after_the_turn(
        number: int, raised: type[BaseException]) -> None:
    done: list[str] = []
    executor = _Executor(_signal_then_work(number, done))
    with StopSignals() as stops:
        stops.defer()
        spinner = BetweenSpins(executor, stops)
        with pytest.raises(raised) as caught:
            spinner.spin_once(timeout_sec=0.05)
        assert done == ["callback finished"]
        stops.hold(caught.value)
        assert stops.first == number
        assert stops.exit_status(1) == 128 + number


def test_a_second_signal_while_the_first_waits_is_raised_where_the_process_is() -> None:
    """A tick stuck in a behaviour never ends its turn: Ctrl-C twice still stops it."""
    reached: list[str] = []

    def stuck() -> None:
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(10_000))
        reached.append("after the first")
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(10_000))
        reached.append("after the second")

    with StopSignals() as stops:
        stops.defer()
        with pytest.raises(KeyboardInterrupt):
            BetweenSpins(_Executor(stuck), stops).spin_once()
    assert reached == ["after the first"]


def test_once_held_a_signal_is_only_noted_and_the_spinner_raises_nothing() -> None:
    done: list[str] = []
    with StopSignals() as stops:
        stops.defer()
        stops.hold()
        executor = _Executor(_signal_then_work(signal.SIGINT, done))
        BetweenSpins(executor, stops).spin_once()
        BetweenSpins(executor, stops).spin_once()
    assert done == ["callback finished"] * 2
    assert stops.received == [signal.SIGINT, signal.SIGINT]


def test_the_spinner_is_the_executor_for_everything_else() -> None:
    executor = _Executor(lambda: None)
    with StopSignals() as stops:
        assert BetweenSpins(executor, stops).turns == 0


def test_a_signal_in_a_subscription_callback_of_the_events_executor_logs_no_fatal_error(
        ros_context: Any, capfd: pytest.CaptureFixture[str]) -> None:
    """Raised inside the callback, Ctrl-C reached rclpy's C++ ``EventsExecutor``, which logged
    "[FATAL] Exception in 'subscriptions' callback" and a stack on stderr before it came out."""
    from rclpy.experimental import EventsExecutor
    from rclpy.node import Node

    node = Node("stopping_test", context=ros_context)
    publisher = node.create_publisher(Empty, "/stopping_test", 10)
    taken: list[str] = []

    def on_message(_message: Empty) -> None:
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(10_000))
        taken.append("taken")

    node.create_subscription(Empty, "/stopping_test", on_message, 10)
    with StopSignals() as stops:
        handlers = {number: signal.getsignal(number) for number in (signal.SIGINT,
                                                                      signal.SIGTERM)}
        executor = EventsExecutor(context=ros_context)
        for number, handler in handlers.items():
            signal.signal(number, handler)
        executor.add_node(node)
        stops.defer()
        spinner = BetweenSpins(executor, stops)
        with pytest.raises(KeyboardInterrupt):
            for _ in range(200):
                publisher.publish(Empty())
                spinner.spin_once(timeout_sec=0.05)
        stops.hold(KeyboardInterrupt())
        executor.shutdown()
    node.destroy_node()
    assert taken == ["taken"]
    assert "FATAL" not in capfd.readouterr().err


@pytest.fixture
def sighup_ignored() -> Iterator[None]:
    """The process as ``nohup`` starts it: SIGHUP ignored."""
    before = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGHUP, before)


def test_a_stop_signal_the_process_was_started_with_ignored_stays_ignored(
        sighup_ignored: None) -> None:
    """``nohup python -m bt_servicesim.evaluate`` must outlive its terminal."""
    with StopSignals() as stops:
        for stage in ("entered", "deferred", "held"):
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN, stage
            os.kill(os.getpid(), signal.SIGHUP)
            sum(range(10_000))
            {"entered": stops.defer, "deferred": stops.hold, "held": lambda: None}[stage]()
        assert signal.getsignal(signal.SIGINT) is not signal.SIG_IGN
        assert stops.received == []
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN


def test_a_child_we_start_and_stop_gets_the_stop_signals_at_their_defaults(
        sighup_ignored: None) -> None:
    """Its parent stops it with a signal: what the user's shell ignored must not keep it on."""
    program = ("import signal; print([signal.getsignal(number) is signal.SIG_IGN "
               "for number in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)])")
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        plain, ours = (subprocess.run([sys.executable, "-c", program], capture_output=True,
                                      text=True, timeout=60, check=True, preexec_fn=preexec)
                       for preexec in (None, parent_death_signal(os.getpid())))
    finally:
        signal.signal(signal.SIGINT, before)
    assert plain.stdout.strip() == "[True, False, True]"  # what the child would inherit
    assert ours.stdout.strip() == "[False, False, False]"


def test_a_user_who_insists_ends_a_clean_up_at_once_with_the_first_signals_status() -> None:
    script = (
        "import os, signal, sys, time\n"
        "from bt_servicesim.mission.stopping import StopSignals\n"
        "with StopSignals() as stops:\n"
        "    stops.hold()\n"
        "    for number in (signal.SIGTERM, signal.SIGINT):\n"
        "        os.kill(os.getpid(), number)\n"
        "        time.sleep(0.05)\n"
        "    print('still cleaning up', flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "    time.sleep(5)\n"
        "    print('clean-up finished', flush=True)\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=60, check=False)
    assert done.returncode == 128 + signal.SIGTERM
    assert done.stdout == "still cleaning up\n"
    lines = done.stderr.splitlines()
    assert lines == ["SIGINT during clean-up: records are being closed; one more stop signal "
                     "ends the process at once",
                     "stopped at once by SIGINT during clean-up: records not written yet are lost"]


# ------------------------------------------------------------------ a closed standard output
@pytest.fixture
def closed_stdout(monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[[], None]]:
    """Puts ``sys.stdout`` on a pipe whose reader has gone, as under ``| head`` once it has its
    lines (Python ignores SIGPIPE: a write raises ``BrokenPipeError``). Called in the test
    itself: pytest puts its own capture back in place between a fixture and the test."""
    reader, writer = os.pipe()
    os.close(reader)
    stream = os.fdopen(writer, "w")
    yield lambda: monkeypatch.setattr(sys, "stdout", stream)
    stream.close()


def test_a_closed_output_stops_as_sigpipe_before_the_mission_defers_signals(
        closed_stdout: Callable[[], None]) -> None:
    closed_stdout()
    with StopSignals() as stops, pytest.raises(Terminated) as stopped:
        print("a line nobody reads", flush=True)
    assert stopped.value.signal_number == signal.SIGPIPE
    assert stops.received == []
    print("and later ones go nowhere, without an error", flush=True)


def test_a_closed_output_while_the_node_spins_is_raised_between_turns(
        closed_stdout: Callable[[], None]) -> None:
    closed_stdout()
    with StopSignals() as stops:
        stops.defer()
        spinner = BetweenSpins(_Executor(lambda: print("progress", flush=True)), stops)
        with pytest.raises(Terminated) as stopped:
            spinner.spin_once()
    assert stopped.value.signal_number == signal.SIGPIPE


def test_a_closed_output_during_clean_up_is_noted_in_the_exit_status(
        closed_stdout: Callable[[], None]) -> None:
    closed_stdout()
    with StopSignals() as stops:
        stops.hold()
        print("mission completed", flush=True)
        print("a second line", flush=True)
    assert stops.received == [signal.SIGPIPE]
    assert stops.exit_status(0) == 128 + signal.SIGPIPE


def test_the_output_is_the_callers_again_after_the_stop_signals(
        closed_stdout: Callable[[], None]) -> None:
    closed_stdout()
    before = sys.stdout
    with StopSignals(), StopSignals():
        assert sys.stdout is not before
    assert sys.stdout is before
