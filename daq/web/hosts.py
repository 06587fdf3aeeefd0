"""The page answers only requests addressed to it by a name it knows (DNS rebinding).

A foreign web page can make the browser resolve its own name (``evil.example``) to
127.0.0.1 and then read and press this server's routes as "same origin". The browser still
sends ``Host: evil.example``; refusing every Host not in the allowed set closes that door
for the page, Zero/Arm, snapshots, events and downloads alike. The allowed set is the
loopback names, the address the server is bound to (unless a wildcard) and the names given
with ``--allow-host`` (a lab PC served to the room names itself there).

`host_name` and `allowed_hosts` are pure; `HostCheck` is the ASGI middleware around them.
"""

from __future__ import annotations

from collections.abc import Iterable

from starlette.responses import PlainTextResponse
from starlette.types import ASGIApp, Receive, Scope, Send

#: Always allowed: this machine by its loopback names.
LOOPBACK_HOSTS = frozenset({"localhost", "127.0.0.1", "::1"})
#: Bind addresses that mean "every interface": not a name a browser would send.
WILDCARD_HOSTS = frozenset({"0.0.0.0", "::", ""})


def host_name(header: str) -> str:
    """The name of a Host header without its port, lower case: ``[::1]:8000`` → ``::1``."""
    value = header.strip().lower()
    if value.startswith("["):                     # [v6]:port
        return value[1:value.find("]")] if "]" in value else value
    if value.count(":") == 1:                     # name:port (a bare v6 address has several)
        return value.split(":", 1)[0]
    return value.rstrip(".")


def allowed_hosts(bind_host: str, extra: Iterable[str] = ()) -> frozenset[str]:
    """Loopback names, the bind address unless a wildcard, and `extra` (names or addresses)."""
    names = set(LOOPBACK_HOSTS) | {host_name(h) for h in extra}
    bind = host_name(bind_host) if ":" not in bind_host or bind_host.startswith("[") \
        else bind_host.lower()
    if bind not in WILDCARD_HOSTS:
        names.add(bind)
    return frozenset(names)


class HostCheck:
    """Refuse (403) any HTTP request whose Host is not in `allowed`; lifespan passes."""

    def __init__(self, app: ASGIApp, allowed: frozenset[str]) -> None:
        self.app = app
        self.allowed = allowed

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] in ("http", "websocket"):
            headers = dict(scope.get("headers") or [])
            raw = headers.get(b"host", b"").decode("latin-1")
            if host_name(raw) not in self.allowed:
                known = ", ".join(sorted(self.allowed))
                response = PlainTextResponse(
                    f"host: expected one of {known}, got {raw!r} (requests addressed by another "
                    "name are refused against DNS rebinding; serve with --allow-host NAME to "
                    "add a name)", status_code=403)
                await response(scope, receive, send)
                return
        await self.app(scope, receive, send)
