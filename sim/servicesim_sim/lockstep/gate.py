"""The lockstep gate: when may the simulator step past a period, and in which order are the
requests of that period served. No ROS here; :mod:`servicesim_sim.lockstep.server` wires it up.

Design intent: a seed is a replayable fact only if the world's history does not depend on how
fast the processes run. So, once a client has joined, the simulator does not step past period
*k* until

* every joined client has said it finished its tick for *k* − ``lag`` (its *done*, with the
  number of requests it has sent on each endpoint since it joined), and
* the simulator has taken at least that many requests on each endpoint.

With ``lag`` 1 (the simulator's: :data:`PIPELINE_LAG`) the two processes work at once: the
simulator steps period *k*+1 while the client ticks on *k*, and the requests of tick *k* are
served after period *k*+1, one period later than with ``lag`` 0, but always then. A client is
never waited on for a period before the one it joined at (its first done, sent at the join,
is for that period), and the requests counted are those of the done for exactly the period
waited on: a client already done with a later period (it may be, one period ahead of the
simulator's wait) has its later requests served a period later, never early.

DDS orders nothing across topics and writers, so the gate never relies on arrival order: the
done message and the requests it counts may arrive in any order, and a request taken while
the gate is shut is not served at once but *admitted* later, when the gate opens, in a fixed
order: by endpoint (sorted by name), then in the order the endpoint took them (one writer's
order, which DDS keeps). Requests beyond what the clients announced wait for the period whose
done announces them, so a request sent from a callback between two ticks is served with the
tick whose done counted it, never earlier by luck.

A done also says which topics the client subscribed to after its join and from which period
it counts each (:class:`Reading`). Those readings decide a period as the requests do: what the
done the gate waits on says (:meth:`LockstepGate.readers_next`), never a later done that
happened to come early, so the simulator publishes a topic it renders only for readers (the
camera) from exactly the period the client named.

A client that goes silent -- the gate waiting on it for :data:`DROP_AFTER_S` of wall time --
is dropped, so a dead client never hangs the simulator; the caller says so. Counts are totals
per endpoint: with several lockstep clients on one endpoint the gate still waits for all of
their requests, but cannot tell whose request is whose (rclpy hides the request's writer
from a service callback); the evaluation runs one client per simulator.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

__all__ = ["DROP_AFTER_S", "PIPELINE_LAG", "Admission", "LockstepGate", "Reading", "allowed_by"]

DROP_AFTER_S = 10.0
"""Wall seconds the gate waits on a client before it drops the client."""
PIPELINE_LAG = 1
"""Periods the simulator may run ahead of its clients' done messages (see the docstring)."""


@dataclass(frozen=True)
class Reading:
    """A subscription a client made after its join, counted by the client from ``start``."""

    topic: str
    start: int
    """The first period whose messages on ``topic`` the client counts."""


_NO_REQUESTS: dict[str, int] = {}
"""A client's counts before its first done (shared: never changed)."""


@dataclass
class _Client:
    name: str
    baseline: dict[str, int]
    """What the simulator had taken on each endpoint when the client joined."""
    joined_period: int = -1
    """The period announced when the client joined: it is never waited on for an earlier one."""
    done_period: int = -1
    requests: dict[int, dict[str, int]] = field(default_factory=dict)
    """The requests each done counted, by period (those no longer needed are forgotten).
    Consecutive dones with the same counts share one dict: nobody changes them."""
    said: tuple[dict[str, int], dict[str, int]] | None = None
    """The last done's counts as it said them, and as kept (endpoints the gate serves)."""
    readings: dict[int, tuple[Reading, ...]] = field(default_factory=dict)
    """What each done said the client reads (none: nothing), by period, kept as requests."""

    def latest_by(self, period: int) -> int | None:
        """The period of the latest done for ``period`` or before (None: none yet)."""
        counted = [done for done in self.requests if done <= period]
        return max(counted) if counted else None

    def requests_by(self, period: int) -> dict[str, int]:
        """The counts of the latest done for ``period`` or before (none: nothing yet)."""
        latest = self.latest_by(period)
        return _NO_REQUESTS if latest is None else self.requests[latest]

    def readings_by(self, period: int) -> tuple[Reading, ...]:
        """What the latest done for ``period`` or before said the client reads."""
        latest = self.latest_by(period)
        return () if latest is None else self.readings.get(latest, ())


@dataclass(order=True)
class Admission:
    """A request taken while the gate was shut, served when the gate admits it."""

    endpoint: str
    number: int
    """Its place in the endpoint's requests (1 for the first the simulator ever took)."""
    serve: Callable[[], None] = field(compare=False)


def allowed_by(sources: list[tuple[dict[str, int], dict[str, int]]]) -> dict[str, int]:
    """Per endpoint, the sum of the clients' baselines and counts (``sources``, a pair for
    each client)."""
    allowed: dict[str, int] = {}
    for baseline, requests in sources:
        for endpoint in set(baseline) | set(requests):
            allowed[endpoint] = (allowed.get(endpoint, 0) + baseline.get(endpoint, 0)
                                 + requests.get(endpoint, 0))
    return allowed


class LockstepGate:
    """Who joined, what they announced, what was taken; see the module docstring."""

    def __init__(self, *, drop_after_s: float = DROP_AFTER_S, lag: int = 0) -> None:
        if lag < 0:
            raise ValueError(f"lag {lag}: must be 0 or more")
        self.drop_after_s = drop_after_s
        self.lag = lag
        """Periods the simulator may run ahead of the clients' done messages."""
        self.period = -1
        """The last period announced."""
        self.taken: dict[str, int] = {}
        self.endpoints: set[str] = set()
        """The endpoints the simulator serves; a client's counts on others (a topic it
        publishes for someone else) are ignored."""
        self._clients: dict[int, _Client] = {}
        self._next_id = 1
        self._waiting_since: float | None = None
        self._admissions: list[Admission] = []
        self._allowed: dict[str, int] = {}
        """:meth:`allowed`, looked at again only after a change of what it depends on (a join,
        a leave, a done, an announcement, a drop): the loop asks for it on every look."""
        self._allowed_stale = True
        self._allowed_from: list[tuple[dict[str, int], dict[str, int]]] = []
        """What the last :meth:`allowed` was worked out from: each client's baseline and
        counts. A new done with the counts of the last one gives the same dicts again."""

    @property
    def active(self) -> bool:
        """Whether any client is joined: only then does the gate hold anything."""
        return bool(self._clients)

    def client_names(self) -> list[str]:
        return [client.name for client in self._clients.values()]

    def join(self, name: str) -> int:
        """A new client, held to the period last announced; its id."""
        client_id = self._next_id
        self._next_id += 1
        self._allowed_stale = True
        self._clients[client_id] = _Client(name=name or f"client {client_id}",
                                           baseline=dict(self.taken), joined_period=self.period)
        return client_id

    def waits_for(self, client: _Client) -> int:
        """The period whose done the gate waits for from ``client`` now."""
        return max(self.period - self.lag, client.joined_period)

    def done(self, client_id: int, period: int, requests: dict[str, int],
             readings: tuple[Reading, ...] = ()) -> bool:
        """A client finished its tick for ``period``, having sent ``requests`` and reading
        ``readings``; False if nobody by that id is joined."""
        client = self._clients.get(client_id)
        if client is None:
            return False
        if period > client.done_period:
            self._allowed_stale = True
            client.done_period = period
            if client.said is None or client.said[0] != requests:
                client.said = (requests, {endpoint: count for endpoint, count in requests.items()
                                          if endpoint in self.endpoints})
            client.requests[period] = client.said[1]
            if readings:
                client.readings[period] = readings
            self._forget_old(client)
        return True

    def _forget_old(self, client: _Client) -> None:
        """Keep the done the gate waits on (the latest up to that period) and later ones."""
        needed = [done for done in client.requests if done <= self.waits_for(client)]
        for old in [done for done in client.requests if needed and done < max(needed)]:
            del client.requests[old]
            client.readings.pop(old, None)

    def readers_next(self) -> dict[str, int]:
        """The topics the joined clients read in the period stepped next, each with the
        number of subscriptions that read it: as the done the gate waits on (or the latest
        before it) says, for readings counted from that period or before."""
        step = self.period + 1
        readers: dict[str, int] = {}
        for client in self._clients.values():
            if not client.readings:  # most periods: nobody subscribed since the join
                continue
            for reading in client.readings_by(self.waits_for(client)):
                if reading.start <= step:
                    readers[reading.topic] = readers.get(reading.topic, 0) + 1
        return readers

    def leave(self, client_id: int) -> str | None:
        """A client leaves: the gate no longer waits for it; its name, None if unknown."""
        client = self._clients.pop(client_id, None)
        self._allowed_stale = True
        return None if client is None else client.name

    def take(self, endpoint: str) -> int:
        """The simulator took a request on ``endpoint``; its number on that endpoint."""
        number = self.taken.get(endpoint, 0) + 1
        self.taken[endpoint] = number
        return number

    def admit_later(self, admission: Admission) -> None:
        self._admissions.append(admission)

    def announced(self, period: int) -> None:
        """Period ``period`` is over and announced; the gate waits on it from now."""
        self.period = period
        self._waiting_since = None
        self._allowed_stale = True

    def allowed(self) -> dict[str, int]:
        """Per endpoint, the requests the joined clients' done messages account for (the
        caller must not change it)."""
        if self._allowed_stale:
            sources = [(client.baseline, client.requests_by(self.waits_for(client)))
                       for client in self._clients.values()]
            last = self._allowed_from
            if len(sources) != len(last) or any(
                    baseline is not old_baseline or requests is not old_requests
                    for (baseline, requests), (old_baseline, old_requests) in zip(
                        sources, last, strict=True)):
                self._allowed, self._allowed_from = allowed_by(sources), sources
            self._allowed_stale = False
        return self._allowed

    def missing(self) -> list[str]:
        """What the gate still waits for before the next step, in words; empty when open."""
        lacking = [f"done {self.waits_for(client)} from {client.name}"
                   for client in self._clients.values()
                   if client.done_period < self.waits_for(client)]
        if lacking:
            return lacking
        return [f"{count - self.taken.get(endpoint, 0)} request(s) on {endpoint}"
                for endpoint, count in sorted(self.allowed().items())
                if self.taken.get(endpoint, 0) < count]

    def lacks_done(self) -> bool:
        """Whether some client has not said it is done with the period the gate waits on
        (:meth:`waits_for`, written out: the loop asks on every look)."""
        waited = self.period - self.lag
        for client in self._clients.values():
            done = client.done_period
            if done < waited or done < client.joined_period:  # done < max(both)
                return True
        return False

    def is_open(self) -> bool:
        """Whether the simulator may step on: :meth:`missing` would be empty. Asked every
        period, so it checks without putting what is missing into words or sorting it."""
        if self.lacks_done():
            return False
        taken = self.taken
        return all(taken.get(endpoint, 0) >= count for endpoint, count in self.allowed().items())

    def due_admissions(self) -> list[Admission]:
        """The admissions to serve now, in their fixed order; the rest wait."""
        if not self._admissions:  # most periods: nothing taken while the gate was shut
            return []
        allowed = self.allowed() if self.active else None
        due = sorted(admission for admission in self._admissions
                     if allowed is None or admission.number <= allowed.get(admission.endpoint, 0))
        for admission in due:
            self._admissions.remove(admission)
        return due

    def drop_silent(self, now_s: float) -> list[str]:
        """Drop the clients the gate has waited on for too long (wall ``now_s``); their names.

        If every client has done its tick and requests are missing, the gate cannot tell whose
        they are: then every client is dropped.
        """
        if self.is_open():
            self._waiting_since = None
            return []
        if self._waiting_since is None:
            self._waiting_since = now_s
            return []
        if now_s - self._waiting_since < self.drop_after_s:
            return []
        silent = [client_id for client_id, client in self._clients.items()
                  if client.done_period < self.waits_for(client)] or list(self._clients)
        names = [self._clients.pop(client_id).name for client_id in silent]
        self._waiting_since = None
        self._allowed_stale = True
        return names

    def overdue(self, now_s: float) -> bool:
        """Whether :meth:`drop_silent` at wall ``now_s`` would drop a client: the gate has
        been shut for :attr:`drop_after_s` (so the caller puts what it lacked into words only
        then)."""
        return (self._waiting_since is not None
                and now_s - self._waiting_since >= self.drop_after_s and not self.is_open())
