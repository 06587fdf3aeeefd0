"""The bench page's HTTP routes (Starlette).

| route | what |
|---|---|
| `GET /` | the page (`static/index.html`; JS and CSS under `/static/`, no CDN) |
| `GET /api/events?bench=B` | server-sent events: `snapshot`, then `samples`, `state`, `status`, `run`, `benches` |
| `GET /api/snapshot?bench=B` | the same snapshot as JSON |
| `POST /api/bench/B/zero` and `/arm` | the daq's queryable; `{ok, message, reply}` (header `X-Cartlab-Action: 1`) |
| `GET /api/stats` | counters of the display path (samples in, events sent, pages) |
| `GET /files/R/mcap?bench=B` | the run's MCAP file (from the runs dir, else the daq's `run` queryable) |
| `GET /files/R/fit/F` | a file of the run's fit folder (report, figures) |

Names in paths are checked by `schemas.keys.check_name`; files never leave the runs dir.
Every route answers only to a Host the server knows (`daq.web.hosts`: DNS rebinding).
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, PlainTextResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from daq.web.files import RunFileError, fit_file_path, mcap_path
from daq.web.hosts import HostCheck, allowed_hosts
from daq.web.hub import Event
from daq.web.service import WebService
from schemas import keys, topics
from schemas.errors import SchemaError

STATIC_DIR = Path(__file__).with_name("static")
#: Header the page sets on Zero/Arm: a cross-site form or `fetch` cannot send it without a
#: CORS preflight, which this server never grants, so other sites cannot press the buttons.
ACTION_HEADER = "X-Cartlab-Action"
#: Seconds between SSE comments that keep idle connections (and proxies) open.
KEEPALIVE_S = 15.0


def sse_frame(event: Event) -> bytes:
    data = json.dumps(event.data, separators=(",", ":"), allow_nan=False)
    return f"event: {event.name}\ndata: {data}\n\n".encode()


def _bench_param(request: Request) -> str | None:
    bench = request.query_params.get("bench") or None
    return None if bench is None else keys.check_name("bench", bench)


def build_app(service: WebService, bind_host: str = "127.0.0.1") -> Starlette:
    """The Starlette app around a (not yet started) `WebService`, served on `bind_host`."""

    @asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        await service.start()
        try:
            yield
        finally:
            await service.stop()

    async def index(request: Request) -> Response:
        return FileResponse(STATIC_DIR / "index.html", headers={"Cache-Control": "no-cache"})

    async def snapshot(request: Request) -> Response:
        bench = _bench_param(request) or service.hub.default_bench()
        return JSONResponse(service.hub.snapshot(bench))

    async def events(request: Request) -> Response:
        bench = _bench_param(request) or service.hub.default_bench()
        client = service.broadcaster.add(bench)

        async def stream() -> AsyncIterator[bytes]:
            try:
                yield sse_frame(Event("snapshot", bench, service.hub.snapshot(bench)))
                while True:
                    try:
                        event = await asyncio.wait_for(client.queue.get(), KEEPALIVE_S)
                    except TimeoutError:
                        yield b": keepalive\n\n"
                        continue
                    if event is None:
                        return
                    yield sse_frame(event)
            finally:
                service.broadcaster.remove(client)

        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})

    async def action(request: Request) -> Response:
        if request.headers.get(ACTION_HEADER) != "1":
            return PlainTextResponse(f"expected the {ACTION_HEADER}: 1 header the page sends, got none "
                                     "(cross-site requests are refused)", status_code=403)
        bench = keys.check_name("bench", request.path_params["bench"])
        name = request.path_params["action"]
        if name not in ("zero", "arm"):
            return PlainTextResponse(f"action: expected zero or arm, got {name!r}", status_code=404)
        result = await (service.zero(bench) if name == "zero" else service.arm(bench))
        return JSONResponse(result, status_code=200 if result["ok"] else 502)

    async def stats(request: Request) -> Response:
        return JSONResponse({
            "samples_in": service.hub.samples_in,
            "events_sent": service.broadcaster.events_sent,
            "pages": len(service.broadcaster.clients),
            "pages_dropped": service.broadcaster.clients_dropped,
            "flushes": service.flushes,
            "bad_messages": service.bad_messages,
            "display_hz": service.settings.display_hz,
        })

    def runs_dir() -> Path:
        if service.settings.runs_dir is None:
            raise RunFileError("run files: expected a runs directory (--runs-dir), got none")
        return service.settings.runs_dir

    async def mcap_file(request: Request) -> Response:
        run_id = keys.check_name("run_id", request.path_params["run_id"])
        download = {"Content-Disposition": f'attachment; filename="{run_id}{topics.RUN_SUFFIX}"'}
        try:
            return FileResponse(mcap_path(runs_dir(), run_id), headers=download)
        except RunFileError:
            bench = _bench_param(request)
            if bench is None:
                raise
        data = await service.run_bytes(bench, run_id)
        return Response(data, media_type="application/octet-stream", headers=download)

    async def fit_file(request: Request) -> Response:
        run_id = keys.check_name("run_id", request.path_params["run_id"])
        name = keys.check_name("file", request.path_params["name"])
        return FileResponse(fit_file_path(runs_dir(), run_id, name))

    async def bad_name(request: Request, exc: Exception) -> Response:
        return PlainTextResponse(str(exc), status_code=400)

    async def missing_file(request: Request, exc: Exception) -> Response:
        return PlainTextResponse(str(exc), status_code=404)

    routes = [
        Route("/", index),
        Route("/api/snapshot", snapshot),
        Route("/api/events", events),
        Route("/api/stats", stats),
        Route("/api/bench/{bench}/{action:str}", action, methods=["POST"]),
        Route("/files/{run_id}/mcap", mcap_file),
        Route("/files/{run_id}/fit/{name}", fit_file),
        Mount("/static", StaticFiles(directory=STATIC_DIR), name="static"),
    ]
    handlers: dict[Any, Any] = {SchemaError: bad_name, RunFileError: missing_file}
    hosts = allowed_hosts(bind_host, service.settings.allow_hosts)
    app = Starlette(routes=routes, lifespan=lifespan, exception_handlers=handlers,
                    middleware=[Middleware(HostCheck, allowed=hosts)])
    app.state.service = service
    return app

