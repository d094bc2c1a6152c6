"""A minimal Groot2 client for the monitor's tests: one request, its reply frames."""

from __future__ import annotations

import itertools

import zmq

from bt_servicesim.monitor.groot2_protocol import RequestHeader

_IDS = itertools.count(1)


def ask(port: int, kind: str, *extra: bytes, timeout_ms: int = 5000,
        host: str = "127.0.0.1") -> list[bytes]:
    """Send one request of type ``kind`` and return the reply's frames."""
    header = RequestHeader(request_type=ord(kind), unique_id=next(_IDS)).to_bytes()
    return exchange(port, [header, *extra], timeout_ms=timeout_ms, host=host)


def exchange(port: int, frames: list[bytes], *, timeout_ms: int = 5000,
             host: str = "127.0.0.1") -> list[bytes]:
    """Send ``frames`` as one request and return the reply's frames."""
    socket = zmq.Context.instance().socket(zmq.REQ)
    socket.setsockopt(zmq.LINGER, 0)
    socket.setsockopt(zmq.RCVTIMEO, timeout_ms)
    socket.connect(f"tcp://{host}:{port}")
    try:
        socket.send_multipart(frames)
        return socket.recv_multipart()
    finally:
        socket.close()


def free_port(*, consecutive: int = 1) -> int:
    """A port on 127.0.0.1 nobody listens on, with the ``consecutive - 1`` after it free too
    (BehaviorTree.CPP's publisher takes two)."""
    import socket

    for _ in range(100):
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        if port + consecutive <= 65536 and all(_free(port + n) for n in range(consecutive)):
            return port
    raise RuntimeError("no free port on 127.0.0.1")


def _free(port: int) -> bool:
    import socket

    with socket.socket() as probe:
        try:
            probe.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True
