"""Fan-out of hub events to the connected pages, one bounded queue per page.

A page that does not keep up (its queue is full) is dropped: its stream ends, the
browser's `EventSource` reconnects by itself and starts again from a fresh snapshot.
Nothing here blocks; it runs on the event loop only.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field

from daq.web.hub import Event

#: Events a page may lag behind before it is dropped (about 10 s at 20 flushes/s).
CLIENT_QUEUE_EVENTS = 256


@dataclass(eq=False)
class Client:
    """One connected page, following `bench`. `None` in its queue ends its stream."""

    bench: str | None
    queue: asyncio.Queue[Event | None] = field(
        default_factory=lambda: asyncio.Queue(CLIENT_QUEUE_EVENTS))
    dropped: bool = False


class Broadcaster:
    def __init__(self) -> None:
        self.clients: set[Client] = set()
        self.events_sent = 0
        self.clients_dropped = 0

    def add(self, bench: str | None) -> Client:
        client = Client(bench)
        self.clients.add(client)
        return client

    def remove(self, client: Client) -> None:
        self.clients.discard(client)

    def _drop(self, client: Client) -> None:
        while not client.queue.empty():
            client.queue.get_nowait()
        client.queue.put_nowait(None)
        client.dropped = True
        self.clients_dropped += 1
        self.clients.discard(client)

    def publish(self, events: list[Event]) -> None:
        for client in list(self.clients):
            for event in events:
                if event.bench is not None and event.bench != client.bench:
                    continue
                try:
                    client.queue.put_nowait(event)
                except asyncio.QueueFull:
                    self._drop(client)
                    break
                self.events_sent += 1

    def close_all(self) -> None:
        for client in list(self.clients):
            self._drop(client)
