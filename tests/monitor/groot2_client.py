"""A minimal Groot2 client for the monitor's tests: one request, its reply frames."""

from __future__ import annotations

import itertools

import zmq

from bt_servicesim.monitor.groot2_protocol import RequestHeader

_IDS = itertools.count(1)


def ask(port: int, kind: str, *extra: bytes, timeout_ms: int = 5000,
        host: str = "127.0.0.1") -> list[bytes]:
    """Send one request of type ``kind`` and return the reply's frames."""
    context = zmq.Context.instance()
    socket = context.socket(zmq.REQ)
    socket.setsockopt(zmq.LINGER, 0)
    socket.setsockopt(zmq.RCVTIMEO, timeout_ms)
    socket.connect(f"tcp://{host}:{port}")
    try:
        header = RequestHeader(request_type=ord(kind), unique_id=next(_IDS)).to_bytes()
        socket.send_multipart([header, *extra])
        return socket.recv_multipart()
    finally:
        socket.close()
