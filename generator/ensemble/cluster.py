"""Where an ensemble runs: a given Dask client, a running scheduler, or a local cluster.

Input: a `distributed.Client`, a scheduler address (``tcp://host:port`` or ``tls://...``) or
neither, a worker count for the local cluster, a connection timeout, a Dask `Security` (TLS,
see `admission.tls_security`) and a dashboard address. Output (`connect`, a context manager):
a connected client with at least one worker, or None for ``workers=0`` (run serially in this
process); a local cluster started here (worker processes, one thread each, one per core by
default) is closed on exit, a given client is left open.

A local cluster listens on 127.0.0.1 only; with a `Security` every connection in it is TLS
with certificates signed by its CA. Its dashboard is off unless an address is given: no
dashboard application, and the scheduler's and workers' HTTP servers (which Dask always
starts) serve no routes (no metrics, no JSON, no health page). With a `Security`, a scheduler
address must be ``tls://``.

An unreachable scheduler or one without workers is an `EnsembleError` (one line).

Example:
    >>> with connect(workers=1) as client:  # doctest: +SKIP
    ...     len(client.scheduler_info()["workers"])
    1
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from .members import EnsembleError
from .requirements import require

__all__ = ["CONNECT_TIMEOUT", "connect", "worker_count"]

#: Seconds to wait for a scheduler to answer and to have a worker.
CONNECT_TIMEOUT = 10.0


def needs_cluster(client: Any = None, workers: int | None = None) -> tuple[str, ...]:
    """The packages `connect` needs for `client` and `workers`: none for a serial run.

    Example:
        >>> needs_cluster(None, 0), needs_cluster(None, 2)
        ((), ('dask', 'distributed'))
    """
    return () if client is None and workers == 0 else ("dask", "distributed")


@contextmanager
def connect(
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    timeout: float = CONNECT_TIMEOUT,
    security: Any = None,
    dashboard: str | None = None,
) -> Iterator[Any]:
    """A connected Dask client: `client` as given, one for `scheduler`, or a local cluster of
    `workers` processes (default: one per core); None when `workers` is 0 (serial).
    `security`: a `distributed.security.Security` for the connections made here; `dashboard`:
    the local cluster's dashboard address (e.g. ``127.0.0.1:8787``), None for none."""
    if client is None and scheduler is None and workers == 0:
        yield None
        return
    require(*needs_cluster(client or scheduler, workers))
    from distributed import Client

    if client is not None:
        yield client
        return
    if scheduler is not None:
        if security is not None and not scheduler.startswith("tls://"):
            raise EnsembleError(
                f"TLS was asked for but the scheduler address {scheduler} is not tls://"
            )
        try:
            c = Client(scheduler, timeout=f"{timeout}s", set_as_default=False, security=security)
        except (OSError, ValueError) as exc:  # TimeoutError and refused connections are OSErrors
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise EnsembleError(
                f"cannot reach the Dask scheduler at {scheduler}: {reason}"
            ) from None
        try:
            _wait_for_workers(c, scheduler, timeout)
            yield c
        finally:
            c.close()
        return
    count = workers if workers is not None else (os.cpu_count() or 1)
    if count < 1:
        raise EnsembleError(f"workers must be at least 1 for a local cluster (got {count})")
    cluster = _local_cluster(count, security, dashboard)
    try:
        c = Client(cluster, set_as_default=False, security=security)
        try:
            yield c
        finally:
            c.close()
    finally:
        cluster.close()


#: The HTTP routes of a local cluster without a dashboard: none (Dask starts its HTTP servers
#: whatever the dashboard setting; with no routes they answer nothing).
_NO_ROUTES: dict[str, list[str]] = {
    "distributed.scheduler.http.routes": [],
    "distributed.worker.http.routes": [],
}


#: The local cluster's background work, cut to what an ensemble needs: the workers' sampling
#: profiler (a stack walk every 10 ms in every worker, competing with the members for the
#: cores; it feeds only the dashboard's profile page), the event loops' health tick (every
#: 20 ms) and the scheduler's work stealing (a rebalancing pass every 100 ms; the ensemble
#: keeps each worker's queue at `dispatch.WINDOW_PER_WORKER` tasks itself).
_QUIET: dict[str, Any] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "200ms",
    "distributed.scheduler.work-stealing": False,
}


def _local_cluster(count: int, security: Any, dashboard: str | None) -> Any:
    """A `LocalCluster` of `count` one-thread worker processes on 127.0.0.1."""
    import dask
    from distributed import LocalCluster

    settings = _QUIET if dashboard else {**_QUIET, **_NO_ROUTES}
    with dask.config.set(settings):  # workers inherit the config
        return LocalCluster(
            n_workers=count,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            protocol="tls://" if security is not None else None,
            security=security,
            dashboard_address=dashboard or "127.0.0.1:0",
            scheduler_kwargs={"dashboard": bool(dashboard)},
            silence_logs=logging.ERROR,
        )


def _wait_for_workers(client: Any, where: str, timeout: float) -> None:
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, TimeoutError):
        raise EnsembleError(
            f"the Dask scheduler at {where} has no workers after {timeout:g} s "
            f"(start some with: dask worker {where})"
        ) from None


def worker_count(client: Any) -> int:
    """Worker processes currently connected to the client's scheduler."""
    return len(client.scheduler_info()["workers"])
