"""uvicorn around the bench page, ending the pages' event streams when asked to stop.

uvicorn waits for open requests before it shuts down, and an event stream stays open for
as long as its page does; `BenchPageServer` ends the streams first, so Ctrl-C (or
`stop()` from another thread) returns at once.
"""

from __future__ import annotations

import socket
from types import FrameType

import uvicorn

from daq.web.app import build_app
from daq.web.service import WebService, WebSettings


class BenchPageServer(uvicorn.Server):
    def __init__(self, settings: WebSettings, host: str = "127.0.0.1", port: int = 8000) -> None:
        self.service = WebService(settings)
        config = uvicorn.Config(build_app(self.service), host=host, port=port, log_level="warning",
                                lifespan="on", timeout_graceful_shutdown=2)
        super().__init__(config)

    def handle_exit(self, sig: int, frame: FrameType | None) -> None:
        self.service.end_streams_threadsafe()
        super().handle_exit(sig, frame)

    def stop(self) -> None:
        """Ask a server running in another thread to stop (thread-safe)."""
        self.service.end_streams_threadsafe()
        self.should_exit = True

    def serve_on(self, sock: socket.socket) -> None:
        """Run on an already bound socket (tests bind port 0 first: no port race)."""
        self.run(sockets=[sock])
