"""``--foxglove``'s address: a port alone binds to loopback, an address is taken as given."""

from __future__ import annotations

import pytest

from bt_servicesim.monitor.live_server import DEFAULT_HOST, DEFAULT_PORT, LiveAddress


@pytest.mark.parametrize(("text", "host", "port"), [
    ("9000", "127.0.0.1", 9000),
    ("0", "127.0.0.1", 0),
    ("0.0.0.0:8765", "0.0.0.0", 8765),
    ("[::1]:8766", "::1", 8766),
])
def test_addresses_parse_to_a_host_and_port(text: str, host: str, port: int) -> None:
    assert LiveAddress.parse(text) == LiveAddress(host=host, port=port)


def test_the_default_is_foxgloves_port_on_loopback() -> None:
    assert (LiveAddress().host, LiveAddress().port) == (DEFAULT_HOST, DEFAULT_PORT)
    assert (DEFAULT_HOST, DEFAULT_PORT) == ("127.0.0.1", 8765)
    assert str(LiveAddress(host="::1", port=1)) == "[::1]:1"


@pytest.mark.parametrize("text", ["", "port", "65536", "-1", ":80", "host:", "1.5"])
def test_anything_else_is_refused_with_a_reason(text: str) -> None:
    with pytest.raises(ValueError, match=r"port|address"):
        LiveAddress.parse(text)
