"""Ephemeral TCP ports on 127.0.0.1 for Zenoh listeners and web servers (loopback only)."""

from __future__ import annotations

import socket


def free_port() -> int:
    """A TCP port the kernel just handed out on 127.0.0.1 (free unless someone races for it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def endpoint() -> str:
    """A Zenoh TCP endpoint on a free loopback port: `tcp/127.0.0.1:<port>`."""
    return f"tcp/127.0.0.1:{free_port()}"
