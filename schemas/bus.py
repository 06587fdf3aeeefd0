"""How a cartlab process joins Zenoh: one model shared by `daq` and `ident`.

Defaults are the safe single-machine ones: an embedded peer that listens on loopback only,
with multicast and gossip scouting off (Zenoh's own defaults listen on every interface and
scout by multicast). A lab with a router runs every process as `mode="client"` with
`connect=["tcp/<router>:7447"]` and `listen=[]`, or hands a Zenoh JSON5 file over with
`config_file`, which is then used as it is.

This module builds plain data (a dict / JSON5 text); it does not import `zenoh`:
`zenoh.Config.from_json5(bus.zenoh_json5())` or `zenoh.Config.from_file(bus.config_file)`.
"""

from __future__ import annotations

import json
import re
from typing import Any, Literal

from pydantic import field_validator

from schemas.base import Record

BusMode = Literal["peer", "client", "router"]
DEFAULT_PORT = 7447
DEFAULT_LISTEN = f"tcp/127.0.0.1:{DEFAULT_PORT}"

_ENDPOINT = re.compile(r"(tcp|udp|tls|quic|ws|unixsock-stream)/\S+")


class BusConfig(Record):
    """Zenoh session settings: mode, endpoints, or a config file that overrides them all."""

    mode: BusMode = "peer"
    listen: list[str] = [DEFAULT_LISTEN]  # noqa: RUF012 - pydantic copies defaults per instance
    connect: list[str] = []  # noqa: RUF012 - pydantic copies defaults per instance
    config_file: str | None = None
    shared_memory: bool = False

    @field_validator("listen", "connect")
    @classmethod
    def _endpoints(cls, endpoints: list[str]) -> list[str]:
        for endpoint in endpoints:
            if not _ENDPOINT.fullmatch(endpoint):
                raise ValueError(f"expected an endpoint like 'tcp/127.0.0.1:7447', got {endpoint!r}")
        return endpoints

    @classmethod
    def listener(cls, endpoint: str = DEFAULT_LISTEN) -> BusConfig:
        """A peer that listens on `endpoint` and connects nowhere (what `daq` runs by default)."""
        return cls(listen=[endpoint], connect=[])

    @classmethod
    def connector(cls, endpoint: str = DEFAULT_LISTEN) -> BusConfig:
        """A peer that connects to `endpoint` and listens nowhere (what `ident` runs by default)."""
        return cls(listen=[], connect=[endpoint])

    def zenoh_dict(self) -> dict[str, Any]:
        """The Zenoh configuration as nested dicts (keys as in Zenoh's JSON5 config)."""
        return {
            "mode": self.mode,
            "listen": {"endpoints": list(self.listen)},
            "connect": {"endpoints": list(self.connect)},
            "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
            "transport": {"shared_memory": {"enabled": self.shared_memory}},
        }

    def zenoh_json5(self) -> str:
        """`zenoh_dict()` as JSON5 text (plain JSON, which JSON5 accepts)."""
        return json.dumps(self.zenoh_dict())
