"""Who may take part in an ensemble: TLS between client, scheduler and workers, and workers that
run the same s2gen as the client.

Input: the paths of a CA certificate, a certificate and its key (the command line's
``--tls-ca-file``, ``--tls-cert``, ``--tls-key``), or a connected Dask client. Output: a
`distributed.security.Security` that requires encryption and certificates signed by that CA
on every connection (`tls_security`); this process's `Identity` (the s2gen version, the
generator's fingerprint and the C build flags); `check_workers`, which compares every
connected worker's identity with the client's and raises `EnsembleError` naming the first
worker that differs. Payloads carry the client's identity too, so that a worker that joins
later refuses its tasks instead of computing different numbers (`worker.run_member`).

Why: the payload and the tasks are pickles, so anyone who can reach a plain ``tcp://``
scheduler can run code on its workers; with TLS only holders of a certificate signed by the
CA can connect. And results are bit-identical wherever a member ran only when every worker
emits the same C and compiles it with the same flags.

Example:
    >>> me = identity()
    >>> me.version == __import__("s2gen").__version__, len(me.fingerprint)
    (True, 64)
    >>> me.differences(me)
    ''
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .members import EnsembleError
from .requirements import require

__all__ = ["Identity", "check_workers", "identity", "tls_security"]


@dataclass(frozen=True)
class Identity:
    """What must agree between client and workers for members to be bit-identical wherever
    they run: the s2gen version, the generator's fingerprint (`s2gen.version.fingerprint`)
    and the build flags of the emitted C (`s2gen.build.build_flags`, set by S2GEN_OPT)."""

    version: str
    fingerprint: str
    flags: tuple[str, ...]

    def differences(self, other: Identity) -> str:
        """What `other` (a worker) runs that differs from this one (the client's); "" when
        nothing does.

        Example:
            >>> a = Identity("0.2.0", "ab" * 32, ("-O2",))
            >>> a.differences(Identity("0.1.0", "cd" * 32, ("-O3",)))
            's2gen 0.1.0 (client 0.2.0), generator cdcdcdcdcdcd (client abababababab), flags -O3 (client -O2)'
        """
        out = []
        if other.version != self.version:
            out.append(f"s2gen {other.version} (client {self.version})")
        if other.fingerprint != self.fingerprint:
            out.append(f"generator {other.fingerprint[:12]} (client {self.fingerprint[:12]})")
        if other.flags != self.flags:
            out.append(f"flags {' '.join(other.flags)} (client {' '.join(self.flags)})")
        return ", ".join(out)


def identity() -> Identity:
    """This process's `Identity` (run on each worker by `check_workers`)."""
    from s2gen import version
    from s2gen.build import build_flags

    return Identity(version.__version__, version.fingerprint(), build_flags())


def check_workers(client: Any) -> int:
    """Compare every connected worker's `Identity` with this process's; raise `EnsembleError`
    (one line naming the worker) on the first difference or on a worker that cannot answer.
    The number of workers checked."""
    here = identity()
    answers = client.run(identity, on_error="return")
    for address in sorted(answers):
        theirs = answers[address]
        if not isinstance(theirs, Identity):
            reason = str(theirs).splitlines()[0] if str(theirs) else type(theirs).__name__
            raise EnsembleError(f"worker {address} cannot report its s2gen: {reason}")
        what = here.differences(theirs)
        if what:
            raise EnsembleError(
                f"worker {address} runs {what}; every worker must run the client's s2gen, "
                "generator and build flags (S2GEN_OPT)"
            )
    return len(answers)


def tls_security(ca_file: str | Path, cert: str | Path, key: str | Path | None = None) -> Any:
    """A Dask `Security` for mutual TLS: the CA that signs every participant's certificate,
    this participant's certificate and its key (omit `key` when `cert` holds both). The same
    certificate serves the client and, on a local cluster, its scheduler and workers.

    Example:
        >>> tls_security("no/ca.pem", "no/cert.pem")
        Traceback (most recent call last):
        ...
        s2gen.ensemble.members.EnsembleError: --tls-ca-file no/ca.pem: no such file
    """
    paths = {"--tls-ca-file": ca_file, "--tls-cert": cert, "--tls-key": key}
    for option, path in paths.items():
        if path is not None and not Path(path).is_file():
            raise EnsembleError(f"{option} {path}: no such file")
    require("dask", "distributed")
    from distributed.security import Security

    files: dict[str, Any] = {"tls_ca_file": str(ca_file)}
    for role in ("client", "scheduler", "worker"):
        files[f"tls_{role}_cert"] = str(cert)
        files[f"tls_{role}_key"] = None if key is None else str(key)
    return Security(require_encryption=True, **files)
