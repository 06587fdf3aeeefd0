"""The bench page: a small web server that is a Zenoh client like any other.

It follows every bench's live samples, detector state, finished runs and fit reports,
calls the daqs' queryables (status, zero, arm, runs, run) and serves one page (HTML,
vanilla JS, CSS from `static/`, no build step, no CDN) with live data pushed by
server-sent events. It must not import `ident`. Started by `python -m daq.web`
(`daq serve` once the daq CLI wires it: `daq.web.__main__.main(argv) -> int`).
"""
