"""Foxglove's WebSocket server for a run, opened before anything else starts.

``foxglove-sdk``'s server speaks Foxglove's WebSocket protocol; :class:`LiveServer` opens it on
an address of the user's (:class:`LiveAddress`: 127.0.0.1 and Foxglove's port 8765 unless the
user names others) with a logging context of its own, so that only the run's bridge
(:mod:`bt_servicesim.monitor.foxglove_bridge`) logs to it. It is opened while the run checks
its input: an address in use is the user's error, one line and exit status 2, and no
simulator has been started. No ROS here, and foxglove-sdk (70 ms to import) only when a server
is asked for.

Every channel the server will ever offer is created before it listens (:class:`LiveChannel`).
A client may connect at once (a Foxglove app left open on the address reconnects within a
second, and a script reads the URL as soon as it is printed); foxglove-sdk files the channels
that exist as it registers the client, before it reads a word from it, while a channel added
later can reach a connected client advertised before the server has filed it for that
client, and the client's subscription to it is then refused ("unknown channel"): a whole live
run without that topic.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from foxglove import Channel, Context
    from foxglove.websocket import ChannelView, Client, ServerListener

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765  # Foxglove's convention
SERVER_NAME = "bt_servicesim"


class LiveServerError(RuntimeError):
    """The live server could not be opened; the message is the one line the user sees."""


@dataclass(frozen=True)
class LiveAddress:
    """Where the live server listens."""

    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT

    @classmethod
    def parse(cls, text: str) -> LiveAddress:
        """``PORT`` or ``ADDR:PORT`` (``[ADDR]:PORT`` for IPv6); port 0 takes a free one.

        Raises:
            ValueError: not an address, or a port outside 0-65535 (the message says which)
        """
        host, separator, port_text = text.strip().rpartition(":")
        host = host.strip("[]") if separator else DEFAULT_HOST
        if separator and not host:
            raise ValueError(f"{text!r}: no address before ':'")
        if not port_text.isdigit() or int(port_text) > 65535:
            raise ValueError(f"{text!r}: the port must be a number from 0 to 65535")
        return cls(host=host, port=int(port_text))

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{host}:{self.port}"


@dataclass(frozen=True)
class LiveChannel:
    """A channel the server offers: a topic and its message type's ``ros2msg`` schema."""

    topic: str
    schema_name: str
    """The message type, ``package/msg/Name``."""
    schema: str
    """Its definition with every type it uses, as a ROS 2 recording stores it."""


class LiveServer:
    """foxglove-sdk's WebSocket server on an address, with a context of its own and its
    channels created before it listens (module docstring)."""

    def __init__(self, address: LiveAddress, *, channels: Sequence[LiveChannel] = ()) -> None:
        import foxglove

        self.address = address
        self.context: Context = foxglove.Context()
        self.channels: dict[str, Channel] = {}
        """The channels by topic, to log to."""
        schemas: dict[str, foxglove.Schema] = {}
        for offered in channels:
            schema = schemas.setdefault(offered.schema_name, foxglove.Schema(
                name=offered.schema_name, encoding="ros2msg", data=offered.schema.encode()))
            self.channels[offered.topic] = foxglove.Channel(
                offered.topic, schema=schema, message_encoding="cdr", context=self.context)
        self._replays: dict[int, Callable[[], None]] = {}
        try:
            self._server = foxglove.start_server(
                name=SERVER_NAME, host=address.host, port=address.port, context=self.context,
                server_listener=_replaying_listener(self._replays), supported_encodings=["cdr"])
        except RuntimeError as error:
            self._close_channels()
            reason = str(error).removeprefix("FoxgloveError: ")
            raise LiveServerError(f"--foxglove {address}: cannot serve there: {reason}") from None

    @property
    def url(self) -> str:
        """The URL to give Foxglove (Open connection, Foxglove WebSocket)."""
        host = f"[{self.address.host}]" if ":" in self.address.host else self.address.host
        return f"ws://{host}:{self._server.port}"

    @property
    def port(self) -> int:
        return self._server.port

    def replay_on_subscribe(self, channel_id: int, replay: Callable[[], None]) -> None:
        """Call ``replay`` whenever a client subscribes to the channel ``channel_id``."""
        self._replays[channel_id] = replay

    def stop(self) -> None:
        """Close the channels and every connection, and stop listening; idempotent."""
        self._close_channels()
        self._server.stop()

    def _close_channels(self) -> None:
        for channel in self.channels.values():
            channel.close()
        self.channels.clear()


def _replaying_listener(replays: dict[int, Callable[[], None]]) -> ServerListener:
    """A server listener that calls a channel's replay whenever a client subscribes to it."""
    from foxglove.websocket import ServerListener

    class ReplayOnSubscribe(ServerListener):
        """Called on the server's own thread; every other event is foxglove's default."""

        def on_subscribe(self, client: Client, channel: ChannelView) -> None:
            replay = replays.get(channel.id)
            if replay is not None:
                replay()

    return ReplayOnSubscribe()


def open_live_server(address: LiveAddress, *,
                     channels: Sequence[LiveChannel] = ()) -> LiveServer:
    """The server, offering ``channels`` and listening; :class:`LiveServerError` when it
    cannot be."""
    return LiveServer(address, channels=channels)


def describe(server: LiveServer) -> str:
    """The line a run prints so the user knows where to point Foxglove."""
    return (f"Foxglove: Open connection, Foxglove WebSocket, {server.url} "
            "(3D panel, display frame map)")
