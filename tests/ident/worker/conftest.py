"""Fixtures of the worker tests: this test process as the bus's router.

- `router`: a Zenoh router session listening on an ephemeral loopback port, with the
  endpoint worker processes connect to as clients (`testkit.worker_harness.client_args`).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from schemas.bus import BusConfig
from testkit.worker_harness import Router, open_session


@pytest.fixture
def router(free_port: int) -> Iterator[Router]:
    endpoint = f"tcp/127.0.0.1:{free_port}"
    session = open_session(BusConfig(mode="router", listen=[endpoint]))
    try:
        yield endpoint, session
    finally:
        session.close()
