"""Access, the default configuration (issue 6, part 5): every default listens on loopback only
and never scouts; the shipped configs parse and keep scouting off."""

from __future__ import annotations

import ipaddress
import json

import zenoh

from schemas.bus import BusConfig
from testkit.secure_bus import WAIT_S
from testkit.waiting import wait_until
from testkit.zenoh_router import DAQ_CLIENT, IDENT_CLIENT, SECURE_ROUTER, VIEWER_CLIENT


def _is_loopback(endpoint: str) -> bool:
    host = endpoint.split("/", 1)[1].rsplit(":", 1)[0].strip("[]")
    return host == "localhost" or ipaddress.ip_address(host).is_loopback


def test_default_bus_config_listens_on_loopback_only_and_never_scouts() -> None:
    conf = BusConfig().zenoh_dict()
    assert conf["listen"]["endpoints"] and all(_is_loopback(e) for e in conf["listen"]["endpoints"])
    assert conf["connect"]["endpoints"] == []
    assert conf["scouting"]["multicast"]["enabled"] is False
    assert conf["scouting"]["gossip"]["enabled"] is False
    # The same once Zenoh has parsed it (Zenoh's own default is tcp/[::]:0 plus multicast).
    parsed = zenoh.Config.from_json5(BusConfig().zenoh_json5())
    assert json.loads(parsed.get_json("scouting/multicast/enabled")) is False
    assert all(_is_loopback(e) for e in json.loads(parsed.get_json("listen/endpoints")))


def test_default_daq_and_worker_command_lines_stay_on_loopback() -> None:
    from daq.cli import _bus_config, build_parser
    from ident.cli import build_parser as ident_parser
    from ident.commands.worker import bus_config as worker_bus_config

    daq_bus = _bus_config(build_parser().parse_args(["run", "--port", "sim://"]))
    assert daq_bus is not None and daq_bus.config_file is None
    assert daq_bus.listen and all(_is_loopback(e) for e in daq_bus.listen)
    worker_bus = worker_bus_config(ident_parser().parse_args(["worker", "--name", "w1"]))
    assert worker_bus.listen == [] and all(_is_loopback(e) for e in worker_bus.connect)


def test_a_session_opened_with_the_default_config_has_only_loopback_links(free_port: int) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port}"
    with zenoh.open(zenoh.Config.from_json5(BusConfig.listener(endpoint).zenoh_json5())) as listener, \
            zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5())) as peer:
        wait_until(lambda: list(peer.info.peers_zid()), WAIT_S, "the peer to link")
        links = list(listener.info.links())
        assert links, "expected the connecting peer to be linked"
        for link in links:
            for locator in (str(link.src), str(link.dst)):
                assert _is_loopback(locator), locator


def test_shipped_configs_parse_and_keep_scouting_off() -> None:
    for path in (SECURE_ROUTER, DAQ_CLIENT, IDENT_CLIENT, VIEWER_CLIENT):
        config = zenoh.Config.from_file(str(path))
        assert json.loads(config.get_json("scouting/multicast/enabled")) is False, path
        assert all(_is_loopback(e) for e in json.loads(config.get_json("listen/endpoints"))), path
    secure = zenoh.Config.from_file(str(SECURE_ROUTER))
    acl = json.loads(secure.get_json("access_control"))
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
