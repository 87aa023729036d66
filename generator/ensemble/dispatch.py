"""Run an ensemble: members to workers (Dask, or this process), results streamed to the store.

Input: a system (a `System` or a spec / built-in name), the members (perturbation replicas
and sweeps, see `members`), the run (method, h, T, options, stride `every`) and where to run
(`client`: a `distributed.Client` or a scheduler address; else a local cluster of `workers`
processes; ``workers=0``: serially in this process). Output: the store
``out/ensemble.zarr`` (see `store`) and an `EnsembleResult` (counts, order written, timings).

Before anything is built or written, every size is checked against its stated limit
(`check_sizes`: members, sweep values and perturbations in `members`, each member's run as
`simulate` checks it, the store's bytes in `store`); after connecting, every worker must run
the client's s2gen version, generator and build flags (`admission.check_workers`).

How it runs on Dask: the system, its emitted C sources (and those of its module with
integrate_batch() where the members can run through it, `batched.run_batched`) and the run's
settings, with the member table, go to every worker once (`client.scatter(...,
broadcast=True)`), and each worker loads its models while the run sets up (`_warm_up`); each task carries a batch of consecutive members (their indices, steps
and parameters; the worker makes their initial states from the table, `worker.task_state`;
`batch_size` of them, by default
chosen by measurement, `batch_size_for`: each worker's warm-up times the first member, and
the first time back sets how many make a task of about `TARGET_TASK_SECONDS`; without one,
one member runs alone on each worker and the first one back sets it). At most `WINDOW_PER_WORKER` tasks
per worker are in flight; as each completes (`distributed.as_completed`) the client fetches
its results, hands them to the store (which writes each chunk of members once, when it is
complete: `chunks`), drops them and
submits the next batch, so the client holds a few batches at a time whatever their number. A
task lost with its worker (killed, disconnected) is resubmitted with its whole batch (up to
`ATTEMPTS` times, re-sending the payload if every copy was lost); a member whose integration
raises is recorded with status -2 and its message (the rest of its batch goes on); a failed
integration is an ordinary result with its partial samples and status. Serially
(``workers=0``) the members run one by one unless `batch_size` groups them (one
integrate_batch() call per group where the system has it). Results are deterministic per member (the same library, the same
inputs), so where a member ran does not change its numbers. With a `Security` (TLS) the
connections made here are encrypted and admit only certificates signed by its CA.

Example:
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     r = ensemble("double_pendulum", members=3, perturb={"omega": 1e-10}, T=0.1,
    ...                  workers=0, out=d)
    ...     r.written, r.failed, sorted(r.order)
    (3, (), [0, 1, 2])
"""

from __future__ import annotations

import itertools
import math
import tempfile
import time
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from s2gen.runtime.options import Options

from .admission import check_workers
from .batched import run_batched, run_packed, unpack, warm_up
from .cluster import CONNECT_TIMEOUT, connect, needs_cluster, worker_count
from .members import MemberTable, initial_state, member_table
from .requirements import require
from .store import EnsembleStore, check_store_size
from .worker import MemberResult, Payload, Task, failed_task, make_payload, run_member

if TYPE_CHECKING:
    from s2gen.system import System

__all__ = [
    "ATTEMPTS",
    "MAX_BATCH",
    "TARGET_TASK_SECONDS",
    "WINDOW_CHECK_SECONDS",
    "WINDOW_PER_WORKER",
    "EnsembleResult",
    "batch_size_for",
    "check_sizes",
    "ensemble",
]

#: Tasks in flight per worker (enough to keep each busy while results travel).
WINDOW_PER_WORKER = 4
#: Seconds between looks at the number of workers (the window grows as workers join).
WINDOW_CHECK_SECONDS = 2.0
#: Submissions of a member whose task was lost with its worker before it is recorded as failed.
ATTEMPTS = 3
#: The integration time a task of several members aims at (seconds): long enough that a
#: task's fixed costs (scheduling, transfers, the store's writes) are small beside it, short
#: enough that a lost task costs little and the workers stay balanced.
TARGET_TASK_SECONDS = 0.2
#: The most members in one task.
MAX_BATCH = 256

Progress = Callable[[MemberResult], None]
Batch = tuple[MemberResult, ...]


def batch_size_for(member_seconds: float, remaining: int, slots: int) -> int:
    """Members per task, from one member's measured integration time: enough for about
    `TARGET_TASK_SECONDS`, at most `MAX_BATCH`, and no more than leaves each of `slots`
    task slots (workers x window) a task of the `remaining` members.

    Example:
        >>> batch_size_for(0.001, 4096, 8), batch_size_for(0.001, 100, 8)
        (200, 13)
        >>> batch_size_for(1.0, 99, 8)
        1
    """
    want = math.ceil(TARGET_TASK_SECONDS / max(member_seconds, 1e-6))
    fair = math.ceil(remaining / max(1, slots))
    return max(1, min(want, MAX_BATCH, fair))


def _batches(tasks: Iterator[Task], size: int) -> Iterator[tuple[Task, ...]]:
    while batch := tuple(itertools.islice(tasks, size)):
        yield batch


@dataclass(frozen=True)
class EnsembleResult:
    """What an ensemble run did. Times in seconds: `setup_time` from the call to the first
    submission (emission, store, cluster start, payload), `wall_time` from the first
    submission to the last member written, `integration_time` the members' own integration
    times added up, `worker_setup_time` the workers' warm-ups and model loads added up."""

    path: Path
    members: int
    written: int
    failed: tuple[int, ...]
    task_errors: tuple[int, ...]
    order: tuple[int, ...]
    workers: int
    setup_time: float
    wall_time: float
    integration_time: float
    worker_setup_time: float


def _resolve(system: System | str | Path) -> System:
    if isinstance(system, (str, Path)):
        import s2gen

        return s2gen.load(system)
    return system


def _tasks(table: MemberTable) -> Iterator[Task]:
    """Each member's task, without its initial state: the worker makes it from the payload's
    table (`worker.task_state`), so the client sends indices, not arrays."""
    for m in table.members:
        yield Task(m.index, m.h, None, None, m.params)


def _attrs(
    system: System, table: MemberTable, payload: Payload, samples: int, command: str | None
) -> dict[str, Any]:
    from s2gen.methods import Status
    from s2gen.version import __version__

    statuses = {str(int(s)): s.message for s in Status}
    statuses.update({"-1": "not written", "-2": "the task raised (see task_errors)"})
    return {
        "system": system.name,
        "n": system.n,
        "parameters": system.parameters,
        "method": payload.method,
        "h": table.h,
        "T": table.T,
        "every": payload.every,
        "samples": samples,
        "options": asdict(payload.options),
        "replicas": table.replicas,
        "perturb": dict(table.perturb),
        "sweeps": {s.name: list(s.values) for s in table.sweeps},
        "seed": table.seed,
        "status_codes": statuses,
        "task_errors": {},
        "generator": __version__,
        "command": command or "",
    }


def check_sizes(
    system: System, table: MemberTable, method: str, every: int, options: Options | None
) -> int:
    """Check every member's run (as `simulate` does) and the store's size against its limit
    before anything is built or written; the samples stored per member.

    Example:
        >>> import s2gen
        >>> s = s2gen.load("double_pendulum")
        >>> check_sizes(s, member_table(s, sweep={"h": [0.01, 0.02]}, T=1.0), "vi", 5, None)
        21
    """
    from s2gen.methods import check_method
    from s2gen.runtime import check_run

    check_method(method, "c")
    steps = sorted({m.h for m in table.members})
    for step in steps:
        check_run(system, method, step, table.T, options, every)
    samples = round(table.T / steps[0]) // every + 1  # the smallest step keeps the most
    check_store_size(len(table), samples, system.n)
    return samples


def ensemble(
    system: System | str | Path,
    members: int | None = None,
    perturb: Mapping[str, float] | None = None,
    sweep: Mapping[str, str | Sequence[float]] | None = None,
    method: str | None = None,
    h: float | None = None,
    T: float | None = None,
    every: int = 1,
    client: Any = None,
    workers: int | None = None,
    out: str | Path | None = None,
    *,
    seed: int = 0,
    options: Options | None = None,
    progress: Progress | None = None,
    timeout: float = CONNECT_TIMEOUT,
    overwrite: bool = False,
    command: str | None = None,
    security: Any = None,
    dashboard: str | None = None,
    batch_size: int | None = None,
) -> EnsembleResult:
    """Integrate every member with the emitted C and write them to ``out/ensemble.zarr``.

    `members` is the number of replicas per sweep point (replica 0 the unperturbed reference;
    default 16 with `perturb`, else 1); `perturb` maps "q" and/or "omega" to a relative size;
    `sweep` maps a parameter name or "h" to ``"START:STOP:COUNT"``, ``"V1,V2"`` or a list.
    `client`: a `distributed.Client` or a scheduler address; without one a local cluster of
    `workers` processes is started (default one per core), and ``workers=0`` runs the members
    one after another in this process. `every` stores every `every`-th sample. `out` defaults
    to a new temporary folder. `security`: a `distributed.security.Security` (TLS, see
    `admission.tls_security`) for the connections made here; `dashboard`: the local cluster's
    dashboard address (default none). When the run starts, every worker must run the client's
    s2gen version, generator and build flags (`admission.check_workers`). `batch_size`:
    members per task (default: by measurement, `batch_size_for`; serially, members per
    write to the store, default 1); the results do not depend on it. Bad input raises
    `EnsembleError` (a ValueError).

    Example:
        >>> r = ensemble("double_pendulum", sweep={"g": [1.0, 9.81]}, T=0.1, workers=0)
        >>> r.members, r.path.name
        (2, 'ensemble.zarr')
    """
    from s2gen import generate
    from s2gen.build import compiler

    start = time.perf_counter()
    if batch_size is not None and not (isinstance(batch_size, int) and batch_size >= 1):
        from .members import EnsembleError

        raise EnsembleError(f"batch_size = {batch_size!r}: must be a positive whole number")
    require("zarr", *needs_cluster(client, workers))
    system = _resolve(system)
    method = method or system.run.method or "vi"
    table = member_table(system, members, perturb, sweep, seed, h, T)
    samples = check_sizes(system, table, method, every, options)
    if client is None:  # local workers compile with this machine's C compiler: one is needed
        compiler()  # BuildError (one line) before anything is written
    batched = None  # the module with integrate_batch(), where the members can run through it
    if client is not None or workers != 0 or batch_size is not None:
        from s2gen.parts.batch import BATCH_METHODS, batch_refusal

        if method in BATCH_METHODS and batch_refusal(system) is None:
            batched = generate(system.with_batch(), "c")
    files = generate(system, "c")
    payload = make_payload(system, files, method, table.T, every, options, batched)
    folder = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix="s2gen-ensemble-"))
    attrs = _attrs(system, table, payload, samples, command)
    address = client if isinstance(client, str) else None
    given = None if isinstance(client, str) else client
    with connect(given, address, workers, timeout, security, dashboard) as c:
        if c is not None:  # connect and admit the workers first: nothing written if not
            check_workers(c)
        store = EnsembleStore.create(folder, table, system.n, samples, attrs, overwrite)
        initial_state(system, table, table.members[0])  # no initial state: one line, here
        payload = replace(payload, table=table)  # the members' states made where they run
        if c is None:  # (a batch's together, `worker.task_states`)
            results = _serial(payload, _tasks(table), batch_size)
            return _collect(store, table, results, 0, start, progress)
        data = c.scatter(payload, broadcast=True, hash=False)
        warm, member = _warm_up(c, data)
        tasks = _tasks(table)
        results = _on_dask(c, data, payload, tasks, system.n, len(table), batch_size, member)
        return _collect(store, table, results, worker_count(c), start, progress, warm)


def _serial(payload: Payload, tasks: Iterator[Task], size: int | None) -> Iterator[Batch]:
    """Every member in this process, in batches of `size` (default 1: each member written,
    and reported, before the next runs): through one integrate_batch() call where the
    payload has that module, else one after another."""
    for batch in _batches(tasks, size or 1):
        done = run_batched(payload, batch) if len(batch) > 1 else None
        if done is not None:
            yield done
            continue
        out = []
        for task in batch:
            try:
                out.append(run_member(payload, task))
            except Exception as exc:  # noqa: BLE001 (record it as the member's outcome, go on)
                out.append(failed_task(task, payload.system.n, f"{type(exc).__name__}: {exc}"))
        yield tuple(out)


def _warm_up(client: Any, data: Any) -> tuple[float, float | None]:
    """Each worker readied for the members while the run sets up (`batched.warm_up`: its
    imports and model loads, which a fresh worker would otherwise pay inside its first
    tasks, and the first member timed): one task per worker, placed on it but free to run
    elsewhere if it leaves. The seconds the loads took, added up, and the first member's
    integration time as the first warm-up back measured it (None if none came back); a
    warm-up that fails is left alone (the members' tasks then load what they need, and
    raise what they raise, as without it)."""
    token = uuid.uuid4().hex[:12]
    futures = [
        client.submit(
            warm_up,
            data,
            key=f"s2gen-warm-up-{token}-{j}",
            workers=[address],
            allow_other_workers=True,
        )
        for j, address in enumerate(client.scheduler_info()["workers"])
    ]
    answers = client.gather(futures, errors="skip")
    for f in futures:
        f.release()
    return float(sum(a[0] for a in answers)), (answers[0][1] if answers else None)


def _lost(exc: BaseException) -> bool:
    """Whether a task failed because its worker or its data went away (worth resubmitting)."""
    from concurrent.futures import CancelledError

    from distributed import KilledWorker
    from distributed.comm.core import CommClosedError

    return isinstance(exc, (KilledWorker, CancelledError, CommClosedError))


def _on_dask(
    client: Any,
    data: Any,
    payload: Payload,
    tasks: Iterator[Task],
    n: int,
    count: int,
    size: int | None,
    member: float | None = None,
) -> Iterator[Batch]:
    """Results as their batches complete on the cluster (`data`: the scattered payload;
    `member`: one member's measured integration time, which sets the batch size when `size`
    is None; without either, one member alone per worker measures it first)."""
    from distributed import as_completed

    token = uuid.uuid4().hex[:12]
    flying: dict[str, tuple[tuple[Task, ...], int]] = {}
    done = as_completed(loop=client.loop)

    def submit(batch: tuple[Task, ...], attempt: int) -> None:
        key = f"s2gen-members-{token}-{batch[0].index}-{len(batch)}-{attempt}"
        future = client.submit(run_packed, data, batch, key=key)
        flying[future.key] = (batch, attempt)
        done.add(future)

    window, checked = 0, -math.inf
    batches: Iterator[tuple[Task, ...]] | None = None
    if size is not None:
        batches = _batches(tasks, size)
    elif member is not None:
        slots = WINDOW_PER_WORKER * max(1, worker_count(client))
        batches = _batches(tasks, batch_size_for(member, count, slots))

    def top_up() -> None:  # keep WINDOW_PER_WORKER tasks per worker in flight, workers may join
        nonlocal window, checked
        if time.monotonic() - checked > WINDOW_CHECK_SECONDS:
            window = WINDOW_PER_WORKER * max(1, worker_count(client))
            checked = time.monotonic()
        if batches is not None:
            for batch in itertools.islice(batches, max(0, window - len(flying))):
                submit(batch, 0)

    probes = 0
    if batches is None:  # one member alone per worker: the first one back sets the batch size
        for task in itertools.islice(tasks, max(1, worker_count(client))):
            submit((task,), 0)
            probes += 1
    else:
        top_up()
    for future in done:
        batch, attempt = flying.pop(future.key)
        try:
            results: Batch = unpack(future.result())
        except Exception as exc:  # noqa: BLE001 (a lost worker is retried, anything else recorded)
            if _lost(exc) and attempt + 1 < ATTEMPTS:
                if data.status != "finished":  # every copy of the payload went with its worker
                    data = client.scatter(payload, broadcast=True, hash=False)
                submit(batch, attempt + 1)
                continue
            results = tuple(failed_task(t, n, f"{type(exc).__name__}: {exc}") for t in batch)
        finally:
            future.release()
        if batches is None:
            slots = WINDOW_PER_WORKER * max(1, worker_count(client))
            seconds = results[0].wall_time if results and results[0].status >= 0 else 0.0
            batches = _batches(tasks, batch_size_for(seconds, count - probes, slots))
        yield results
        top_up()


def _collect(
    store: EnsembleStore,
    table: MemberTable,
    results: Iterator[Batch],
    workers: int,
    start: float,
    progress: Progress | None,
    setup: float = 0.0,
) -> EnsembleResult:
    """Write each batch of results as it arrives; flush the statistics at the end, even on
    interrupt (`setup`: the workers' warm-up seconds, added to their model loads)."""
    first = time.perf_counter()
    order: list[int] = []
    failed: list[int] = []
    errors: list[int] = []
    integration = 0.0
    try:
        for batch in results:
            store.write_many(batch)
            for item in batch:
                order.append(item.index)
                integration += item.wall_time
                setup += item.setup_time
                if item.status > 0:
                    failed.append(item.index)
                elif item.status < 0:
                    errors.append(item.index)
                if progress is not None:
                    progress(item)
    finally:
        store.consolidate()
    end = time.perf_counter()
    return EnsembleResult(
        path=store.path,
        members=len(table),
        written=len(order),
        failed=tuple(sorted(failed)),
        task_errors=tuple(sorted(errors)),
        order=tuple(order),
        workers=workers,
        setup_time=first - start,
        wall_time=end - first,
        integration_time=integration,
        worker_setup_time=setup,
    )
