"""uvicorn around the bench page, ending the pages' event streams when asked to stop.

uvicorn waits for open requests before it shuts down, and an event stream stays open for
as long as its page does; `BenchPageServer` ends the streams first, so Ctrl-C (or
`stop()` from another thread) returns at once.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterator
from types import FrameType

import uvicorn

from daq.web.app import build_app
from daq.web.service import WebService, WebSettings


class BenchPageServer(uvicorn.Server):
    def __init__(self, settings: WebSettings, host: str = "127.0.0.1", port: int = 8000) -> None:
        self.service = WebService(settings)
        config = uvicorn.Config(build_app(self.service, host), host=host, port=port, log_level="warning",
                                lifespan="on", timeout_graceful_shutdown=2)
        super().__init__(config)

    def handle_exit(self, sig: int, frame: FrameType | None) -> None:
        self.service.end_streams_threadsafe()
        super().handle_exit(sig, frame)

    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        # uvicorn re-raises a caught SIGINT/SIGTERM after its graceful shutdown (a
        # KeyboardInterrupt traceback, or death by SIGTERM); a stop on a signal is a clean
        # stop here, so `main()` returns 0.
        with super().capture_signals():
            yield
            self._captured_signals.clear()

    def stop(self) -> None:
        """Ask a server running in another thread to stop (thread-safe)."""
        self.service.end_streams_threadsafe()
        self.should_exit = True

    def serve_on(self, sock: socket.socket) -> None:
        """Run on an already bound socket (tests bind port 0 first: no port race)."""
        self.run(sockets=[sock])


class ThreadedPageServer:
    """A `BenchPageServer` on an ephemeral loopback port in a background thread.

    For tools and tests: `with ThreadedPageServer(settings) as page: page.url ...`.
    """

    def __init__(self, settings: WebSettings, host: str = "127.0.0.1") -> None:
        self.sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
        self.sock.bind((host, 0))
        self.host = host
        self.port = int(self.sock.getsockname()[1])
        self.server = BenchPageServer(settings, host, self.port)
        self.service = self.server.service
        self.thread = threading.Thread(target=self.server.serve_on, args=(self.sock,),
                                       name="bench-page", daemon=True)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def start(self, timeout_s: float = 15.0) -> None:
        self.thread.start()
        ready = threading.Event()
        deadline = time.monotonic() + timeout_s
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError(f"bench page server: expected it started within {timeout_s} s, "
                                   "got " + ("a dead thread" if not self.thread.is_alive() else "no start"))
            ready.wait(0.01)

    def stop(self, timeout_s: float = 10.0) -> None:
        self.server.stop()
        self.thread.join(timeout_s)
        self.sock.close()
        if self.thread.is_alive():
            raise RuntimeError(f"bench page server: expected it stopped within {timeout_s} s")

    def __enter__(self) -> ThreadedPageServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
