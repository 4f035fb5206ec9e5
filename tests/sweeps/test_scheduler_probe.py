"""A ``--scheduler`` address is judged before any work: its form, whether anything answers,
and whether what answers is a Dask scheduler (Dask itself read an HTTP server's first bytes
as a length and tried to allocate exabytes: "out of memory")."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from analysis.errors import InputError
from analysis.sweeps.executors import parse_scheduler, probe_scheduler
from tests.conftest import run_cli


def _server(reply: bytes | None) -> tuple[socket.socket, int]:
    """A local server that sends ``reply`` on every connection (None: accepts and stays
    silent); returns its socket and port."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held = []

    def serve() -> None:
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            if reply is not None:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return srv, srv.getsockname()[1]


@pytest.mark.parametrize(("address", "why"), [
    ("htp://127.0.0.1:8786", "unknown scheme 'htp'"), ("tcp://127.0.0.1", "no port"),
    ("127.0.0.1:", "no port"), ("tcp://:8786", "no host"), ("tcp://h:70000", "port 70000"),
    ("", "no port")])
def test_a_malformed_address_names_what_is_wrong(address, why):
    with pytest.raises(InputError, match=r"^scheduler: must be tcp://HOST:PORT .*" + why):
        parse_scheduler(address)


def test_well_formed_addresses_parse():
    assert parse_scheduler("tcp://10.0.0.5:8786") == ("tcp", "10.0.0.5", 8786)
    assert parse_scheduler("sched.local:8786") == ("tcp", "sched.local", 8786)
    assert parse_scheduler("tls://[::1]:8786/") == ("tls", "::1", 8786)


@pytest.mark.parametrize("reply", [b"HTTP/1.0 400 Bad Request\r\n\r\n", b"\xff" * 64, None],
                         ids=["http", "garbage", "silent"])
def test_what_answers_but_is_no_scheduler_is_named_so_within_seconds(reply):
    srv, port = _server(reply)
    try:
        start = time.monotonic()
        with pytest.raises(InputError, match=r"not a Dask scheduler"):
            probe_scheduler(f"tcp://127.0.0.1:{port}", seconds=1.0)
        assert time.monotonic() - start < 3.0
    finally:
        srv.close()


def test_nothing_listening_is_refused_at_once():
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    port = srv.getsockname()[1]
    srv.close()  # the port is free: nothing listens
    start = time.monotonic()
    with pytest.raises(InputError, match=r"nothing listens at 127\.0\.0\.1"):
        probe_scheduler(f"tcp://127.0.0.1:{port}")
    assert time.monotonic() - start < 2.0


def test_a_real_scheduler_passes_the_probe():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None,
                                  protocol="tcp://", host="127.0.0.1") as cluster:
        probe_scheduler(cluster.scheduler_address)


def test_the_command_says_not_a_dask_scheduler_instead_of_out_of_memory(tmp_path):
    srv, port = _server(b"HTTP/1.0 400 Bad Request\r\n\r\n")
    try:
        start = time.monotonic()
        res = run_cli("sweep", "balanced-rotor", "--param", "speed_rpm", "--from", "7000",
                      "--to", "7100", "--num", "2", "-o", "d.nc", "--scheduler",
                      f"tcp://127.0.0.1:{port}", cwd=tmp_path)
        assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
        assert "not a Dask scheduler" in res.stderr and "memory" not in res.stderr
        assert time.monotonic() - start < 20.0
        assert list(tmp_path.iterdir()) == []
    finally:
        srv.close()
