"""The simulator's servers as one fake: :class:`FakeSimulator`, a referee and a navigator under
one namespace, served from a thread of their own, writing one event log."""

from __future__ import annotations

from bt_servicesim.planning.geometry import Box
from tests.fakes.navigator import FakeNavigator
from tests.fakes.referee import FakeReferee, Task
from tests.fakes.servers import Event, EventLog, ServerThread
from tests.fakes.spinning import unique_name


class FakeSimulator:
    """A :class:`FakeReferee` and a :class:`FakeNavigator` under ``namespace``, served from a
    thread of their own, writing one :class:`EventLog`."""

    def __init__(self, context: object, namespace: str = "", *, task: Task | None = None,
                 rooms: dict[str, Box] | None = None, move_base_clearing: bool = True) -> None:
        self.log = EventLog()
        self.referee = FakeReferee(context, unique_name("fake_referee"), namespace=namespace,
                                   rooms=rooms, task=task, log=self.log,
                                   move_base_clearing=move_base_clearing)
        self.navigator = FakeNavigator(context, f"{namespace}/servicebot/navigate_to_pose",
                                       log=self.log)
        self.navigator.steps = 0
        self.thread = ServerThread(context, self.referee, self.navigator)

    @property
    def events(self) -> list[Event]:
        return self.log.events

    def named(self, what: str) -> list[Event]:
        return self.log.named(what)

    def shutdown(self) -> None:
        self.thread.shutdown()
