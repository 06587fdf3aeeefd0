"""Access over TLS (issue 6, part 5): the commented blocks of the shipped configs made real with
throw-away certificates made by `openssl`: only clients with a certificate of the lab CA get in."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
import zenoh

from schemas import keys
from schemas.bus import BusConfig
from testkit.secure_bus import REFUSE_MS, Inbox, put_until_received
from testkit.zenoh_router import open_router


def _openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True, timeout=30)


def _make_certificates(folder: Path) -> None:
    """A lab CA, a router certificate for localhost/127.0.0.1, a client certificate (CN
    daq-bench1) signed by it, and a client certificate signed by another CA."""
    ec = ("-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes")
    (folder / "server.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\nbasicConstraints=CA:FALSE\n"
                                       "keyUsage=digitalSignature\nextendedKeyUsage=serverAuth\n")
    (folder / "client.ext").write_text("subjectAltName=DNS:daq-bench1\nbasicConstraints=CA:FALSE\n"
                                       "keyUsage=digitalSignature\nextendedKeyUsage=clientAuth\n")
    for ca in ("ca", "rogue-ca"):
        _openssl("req", "-x509", *ec, "-keyout", f"{ca}-key.pem", "-out", f"{ca}.pem", "-days", "1",
                 "-subj", f"/CN=cartlab {ca}", cwd=folder)
    for name, cn, ca, ext in (("router", "localhost", "ca", "server.ext"), ("daq", "daq-bench1", "ca", "client.ext"),
                              ("rogue", "daq-bench1", "rogue-ca", "client.ext")):
        _openssl("req", *ec, "-keyout", f"{name}-key.pem", "-out", f"{name}.csr", "-subj", f"/CN={cn}", cwd=folder)
        _openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{ca}.pem", "-CAkey", f"{ca}-key.pem",
                 "-CAcreateserial", "-out", f"{name}-cert.pem", "-days", "1", "-extfile", ext, cwd=folder)


@pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl is needed to make test certificates")
def test_mutual_tls_lets_in_only_clients_with_a_certificate_of_the_lab_ca(tmp_path: Path, free_port: int) -> None:
    _make_certificates(tmp_path)
    endpoint = f"tls/localhost:{free_port}"
    router = zenoh.Config.from_json5(BusConfig(mode="router", listen=[]).zenoh_json5())
    router.insert_json5("listen/endpoints", json.dumps([endpoint]))
    router.insert_json5("transport/link/tls", json.dumps({
        "listen_private_key": str(tmp_path / "router-key.pem"), "listen_certificate": str(tmp_path / "router-cert.pem"),
        "root_ca_certificate": str(tmp_path / "ca.pem"), "enable_mtls": True}))

    def client(cert: str | None) -> zenoh.Config:
        tls: dict[str, object] = {"root_ca_certificate": str(tmp_path / "ca.pem"), "verify_name_on_connect": True}
        if cert is not None:
            tls.update(connect_private_key=str(tmp_path / f"{cert}-key.pem"),
                       connect_certificate=str(tmp_path / f"{cert}-cert.pem"), enable_mtls=True)
        config = zenoh.Config.from_json5(BusConfig(mode="client", listen=[], connect=[]).zenoh_json5())
        config.insert_json5("connect/endpoints", json.dumps([endpoint]))
        config.insert_json5("connect/timeout_ms", str(REFUSE_MS))
        config.insert_json5("connect/exit_on_failure", "true")
        config.insert_json5("transport/link/tls", json.dumps(tls))
        return config

    with open_router(router):
        for refused in (None, "rogue"):
            with pytest.raises(zenoh.ZError, match="Unable to connect"):
                zenoh.open(client(refused))
        with zenoh.open(client("daq")) as listener, zenoh.open(client("daq")) as sender:
            inbox = Inbox()
            sub = listener.declare_subscriber("cartlab/**", inbox)
            try:
                put_until_received(sender, inbox, keys.samples("bench1"), "over-tls")
            finally:
                sub.undeclare()
