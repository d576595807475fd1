"""Loopback helpers shared by the hardware tests."""

from __future__ import annotations

import socket


def free_port() -> int:
    """A loopback TCP port free a moment ago, for a server started in another process."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]
