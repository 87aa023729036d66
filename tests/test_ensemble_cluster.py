"""A cluster that admits only its own (localhost only): an ensemble over TLS with certificates
made here is bit-identical to the same ensemble run serially, and a client without a
certificate signed by the CA cannot join; a worker that reports another s2gen version or
other build flags is refused by name before anything is written; the local cluster serves no
dashboard and no HTTP routes unless asked."""

from __future__ import annotations

import dataclasses
import datetime
import ipaddress
import os
import socket
import ssl
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from cryptography import x509

import s2gen
from s2gen.cli import main
from s2gen.ensemble import EnsembleError, EnsembleStore, ensemble
from s2gen.ensemble.admission import Identity, identity, tls_security
from s2gen.ensemble.cluster import connect
from s2gen.ensemble.worker import Task, make_payload, run_member


# ------------------------------------------------------------------------------ certificates
def _name(common: str) -> Any:
    from cryptography.x509.oid import NameOID

    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common)])


def _make_tls(folder: Path, ca_name: str = "s2gen test CA") -> tuple[Path, Path, Path]:
    """A fresh CA and a certificate for localhost and 127.0.0.1 signed by it: (ca, cert, key)."""
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec

    now = datetime.datetime.now(datetime.UTC)
    valid = (now - datetime.timedelta(minutes=5), now + datetime.timedelta(days=1))
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca = (
        x509.CertificateBuilder()
        .subject_name(_name(ca_name))
        .issuer_name(_name(ca_name))
        .public_key(ca_key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(valid[0])
        .not_valid_after(valid[1])
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .sign(ca_key, hashes.SHA256())
    )
    key = ec.generate_private_key(ec.SECP256R1())
    names = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
    cert = (
        x509.CertificateBuilder()
        .subject_name(_name("localhost"))
        .issuer_name(ca.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(valid[0])
        .not_valid_after(valid[1])
        .add_extension(x509.SubjectAlternativeName(names), critical=False)
        .sign(ca_key, hashes.SHA256())
    )
    folder.mkdir(parents=True, exist_ok=True)
    paths = (folder / "ca.pem", folder / "cert.pem", folder / "key.pem")
    pem = serialization.Encoding.PEM
    paths[0].write_bytes(ca.public_bytes(pem))
    paths[1].write_bytes(cert.public_bytes(pem))
    paths[2].write_bytes(
        key.private_bytes(pem, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    )
    return paths


def _assert_same_store(a: Path, b: Path) -> None:
    """Every array of two stores bit-identical (timings aside)."""
    x, y = EnsembleStore.open(a), EnsembleStore.open(b)
    assert x.names() == y.names()
    for name in x.names():
        if name not in ("wall_time", "setup_time"):
            u, v = np.asarray(x.array(name)[:]), np.asarray(y.array(name)[:])
            assert np.array_equal(u, v, equal_nan=u.dtype.kind == "f"), name


# ---------------------------------------------------------------------------------------- TLS
def test_an_ensemble_over_tls_is_bit_identical_to_serial(tmp_path: Path) -> None:
    ca, cert, key = _make_tls(tmp_path / "tls")
    run = ["ensemble", "double_pendulum", "--members", "4", "--perturb", "omega=1e-13"]
    run += ["--sweep", "g=5,9.81", "--T", "0.5", "--every", "2"]
    tls = ["--tls-ca-file", str(ca), "--tls-cert", str(cert), "--tls-key", str(key)]
    assert main([*run, *tls, "--workers", "2", "--out", str(tmp_path / "tls-run")]) == 0
    assert main([*run, "--workers", "0", "--out", str(tmp_path / "serial")]) == 0
    _assert_same_store(tmp_path / "tls-run", tmp_path / "serial")
    per = EnsembleStore.open(tmp_path / "tls-run").per_member()
    assert (per["status"] == 0).all() and len(per["status"]) == 8


def _anonymous_tls_is_dropped(address: str, ca: Path) -> bool:
    """Whether the scheduler at `address` ends a TLS connection that trusts its CA but shows
    no certificate of its own, before answering anything."""
    host, port = address.removeprefix("tls://").rsplit(":", 1)
    context = ssl.create_default_context(cafile=str(ca))
    with socket.create_connection((host, int(port)), timeout=10) as raw:
        try:
            with context.wrap_socket(raw, server_hostname=host) as tls:
                return tls.recv(1) == b""
        except (ssl.SSLError, ConnectionResetError):
            return True


def test_a_tls_cluster_admits_only_certificates_of_its_ca(tmp_path: Path) -> None:
    """The local cluster listens on tls:// at 127.0.0.1; a client with a certificate signed by
    another CA, or with none, cannot join it; one with the CA's certificate can."""
    from distributed import Client

    own = tls_security(*_make_tls(tmp_path / "own"))
    other = tls_security(*_make_tls(tmp_path / "other", "another CA"))
    with connect(workers=1, security=own) as c:
        address = c.scheduler_info()["address"]
        assert address.startswith("tls://127.0.0.1:")
        with pytest.raises((OSError, TimeoutError)):  # the scheduler does not trust it
            Client(address, timeout="3s", security=other, set_as_default=False)
        assert _anonymous_tls_is_dropped(address, tmp_path / "own" / "ca.pem")
        with Client(address, timeout="10s", security=own, set_as_default=False) as friend:
            assert len(friend.scheduler_info()["workers"]) == 1


def test_tls_needs_a_tls_scheduler_address_and_existing_files(tmp_path: Path, capsys: Any) -> None:
    ca, cert, key = _make_tls(tmp_path / "tls")
    out = tmp_path / "o"
    base = ["ensemble", "double_pendulum", "--T", "0.1", "--out", str(out)]
    cases = [
        (["--scheduler", "tcp://127.0.0.1:9", "--tls-ca-file", str(ca), "--tls-cert", str(cert)],
         "is not tls://"),
        (["--tls-cert", str(cert), "--tls-key", str(key)], "needs both --tls-ca-file"),
        (["--tls-ca-file", str(tmp_path / "none.pem"), "--tls-cert", str(cert)], "no such file"),
    ]  # fmt: skip
    for extra, message in cases:
        assert main([*base, *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err
    assert not out.exists()


# --------------------------------------------------------------------- workers that differ
@pytest.fixture(scope="module")
def local_client() -> Iterator[Any]:
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    client = Client(cluster)
    yield client
    client.close()
    cluster.close()


def _pretend(version: str | None, opt: str | None) -> None:
    """Make this worker report another s2gen version and/or build flags (S2GEN_OPT)."""
    from s2gen import version as v

    if version is not None:
        v.__version__ = version
        v.fingerprint.cache_clear()  # the fingerprint hashes the version too
    if opt is None:
        os.environ.pop("S2GEN_OPT", None)
    else:
        os.environ["S2GEN_OPT"] = opt


@pytest.mark.parametrize(
    ("version", "opt", "expected"),
    [
        ("9.9.9", None, f"runs s2gen 9.9.9 (client {s2gen.__version__})"),
        (None, "native", "flags -std=c99 -O3 -march=native"),
    ],
)
def test_a_worker_that_differs_is_refused_by_name(
    local_client: Any, tmp_path: Path, version: str | None, opt: str | None, expected: str
) -> None:
    workers = sorted(local_client.scheduler_info()["workers"])
    odd = workers[1]
    local_client.run(_pretend, version, opt, workers=[odd])
    try:
        with pytest.raises(EnsembleError) as info:
            ensemble("double_pendulum", T=0.1, client=local_client, out=tmp_path / "o")
        message = str(info.value)
        assert "\n" not in message and f"worker {odd} " in message and expected in message
        assert not (tmp_path / "o").exists()
    finally:
        local_client.run(_pretend, s2gen.__version__, None, workers=[odd])
    r = ensemble("double_pendulum", T=0.1, client=local_client, out=tmp_path / "ok")
    assert r.written == 1 and r.failed == () and r.task_errors == ()


def test_a_task_on_a_worker_that_differs_is_refused() -> None:
    """A worker that joins after the start check still refuses the tasks of another s2gen."""
    s = s2gen.load("double_pendulum")
    payload = make_payload(s, s2gen.generate(s, "c"), "vi", T=0.1)
    task = Task(0, 0.01, s.q0, s.omega0, ())
    assert run_member(payload, task).status == 0
    client = dataclasses.replace(identity(), version="9.9.9")  # this process is the worker
    with pytest.raises(
        RuntimeError, match=rf"runs s2gen {s2gen.__version__} \(client 9\.9\.9\).*refused"
    ):
        run_member(dataclasses.replace(payload, identity=client), task)
    assert isinstance(payload.identity, Identity)


# ------------------------------------------------------------------------------- dashboard
def _http(port: int, path: str) -> int:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=10) as r:
            return int(r.status)
    except urllib.error.HTTPError as exc:
        return exc.code


def test_the_local_cluster_serves_no_dashboard_unless_asked() -> None:
    """Dask's HTTP servers of the scheduler and of every worker answer nothing (no health
    page, no metrics, no JSON) by default; with a dashboard address they answer."""
    with connect(workers=1) as c:
        info = c.scheduler_info()
        ports = [info["services"]["dashboard"]]
        ports += [w["services"]["dashboard"] for w in info["workers"].values()]
        for port in ports:
            for path in ("/health", "/metrics", "/json/identity.json", "/status"):
                assert _http(port, path) == 404, (port, path)
    with connect(workers=1, dashboard="127.0.0.1:0") as c:
        assert _http(c.scheduler_info()["services"]["dashboard"], "/health") == 200
