"""What runs on a worker: integrate one member with the emitted C and summarise it.

Input: a `Payload` (the system, its emitted C sources and the run's settings; sent once per
worker) and a `Task` (one member: index, step, initial state, parameters). Output: a
`MemberResult` with the stored samples (every `every`-th), the member's statistics over all
its samples, and its status.

A worker needs no shared file system and nothing derived: the C sources travel in the payload;
the first task on a worker thread builds them (content-hash cached in the worker's
`$S2GEN_CACHE`) and loads the library, and every later task with the same sources reuses that
loaded model (`MODEL_CACHE` models per thread, keyed by the sources' sha256). A failed
integration is a result, not an exception: it keeps the samples computed before the failure
and the status code (`s2gen.methods.Status`).

Example:
    >>> import s2gen
    >>> s = s2gen.load("double_pendulum")
    >>> payload = make_payload(s, s2gen.generate(s, "c"), "vi", T=0.1, every=5)
    >>> r = run_member(payload, Task(0, 0.01, s.q0, s.omega0, ()))
    >>> r.status, r.q.shape, r.samples
    (0, (3, 2, 3), 11)
"""

from __future__ import annotations

import hashlib
import math
import os
import socket
import threading
import time
import warnings
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from s2gen.runtime.options import Options

from .admission import Identity, identity

if TYPE_CHECKING:
    from s2gen.runtime.model import Model
    from s2gen.system import System

__all__ = [
    "MODEL_CACHE",
    "TASK_ERROR",
    "MemberResult",
    "Payload",
    "Task",
    "failed_task",
    "make_payload",
    "run_member",
    "sample_statistics",
    "sources_digest",
    "task_state",
    "task_states",
    "thin",
]

#: Loaded models kept per worker thread (least recently used dropped first).
MODEL_CACHE = 4
#: Status of a member whose task raised (not an integration failure): see the message.
TASK_ERROR = -2

_local = threading.local()
_NO_STATE = "member {}: no initial state and no member table to make it"


@dataclass(frozen=True)
class Payload:
    """Everything the members share, sent once to each worker: the system, its emitted C
    sources and their sha256, the method, horizon, stride and options, and the client's
    `Identity` (a worker whose own differs refuses the task)."""

    system: System
    files: dict[str, str]
    digest: str
    method: str
    T: float
    every: int
    options: Options
    identity: Identity
    #: The sources of the module with integrate_batch() (`System.with_batch`), when the
    #: members can run through it (`ensemble.batched`); None otherwise.
    batch_files: dict[str, str] | None = None
    #: The ensemble's `members.MemberTable`, when its tasks leave their initial states to the
    #: worker (`task_state`); None otherwise.
    table: Any = None


@dataclass(frozen=True)
class Task:
    """One member's own inputs: its index, step size, initial state (None: the member's, made
    by the worker from the payload's table, `task_state`) and swept parameters."""

    index: int
    h: float
    q0: np.ndarray | None
    omega0: np.ndarray | None
    params: tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class MemberResult:
    """One member's outcome: stored samples (every `every`-th of the valid ones), statistics
    over all valid samples, status (0 ok, a `Status` code, or `TASK_ERROR`) and timings."""

    index: int
    status: int
    message: str
    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray
    samples: int
    mean_dE: float
    max_dE: float
    max_unit: float
    steps: int
    rejected: int
    gradient_evals: int
    wall_time: float
    setup_time: float
    worker: str

    @property
    def ok(self) -> bool:
        """Whether the integration reached T."""
        return self.status == 0


def sources_digest(files: dict[str, str]) -> str:
    """sha256 over the sources (sorted by name): the key of a loaded model.

    Example:
        >>> len(sources_digest({"a.c": "int x;"}))
        64
    """
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    return h.hexdigest()


def make_payload(
    system: System,
    files: dict[str, str],
    method: str,
    T: float,
    every: int = 1,
    options: Options | None = None,
    batch_files: dict[str, str] | None = None,
    table: Any = None,
) -> Payload:
    """The payload of an ensemble (computes the sources' digest)."""
    opts = options or Options()
    digest = sources_digest({**files, **{f"batch/{k}": v for k, v in (batch_files or {}).items()}})
    return Payload(system, files, digest, method, T, every, opts, identity(), batch_files, table)


def task_state(payload: Payload, task: Task) -> tuple[np.ndarray, np.ndarray]:
    """The task's initial state (q0, omega0): its own, or its member's from the payload's
    table (`members.initial_state`: the same numbers, made on the worker rather than by the
    client, which then only sends indices).

    Example:
        >>> import s2gen
        >>> from s2gen.ensemble.members import member_table
        >>> s = s2gen.load("double_pendulum")
        >>> t = member_table(s, 2, {"omega": 1e-10})
        >>> p = make_payload(s, {}, "vi", T=0.1, table=t)
        >>> q0, w0 = task_state(p, Task(1, 0.01, None, None, ()))
        >>> bool(np.array_equal(q0, s.q0)), bool(np.array_equal(w0, s.omega0))
        (True, False)
    """
    if task.q0 is not None and task.omega0 is not None:
        return task.q0, task.omega0
    from .members import initial_state

    table = payload.table
    if table is None:
        raise ValueError(_NO_STATE.format(task.index))
    return initial_state(payload.system, table, table.members[task.index])


def task_states(
    payload: Payload, tasks: Sequence[Task]
) -> list[tuple[np.ndarray, np.ndarray] | Exception]:
    """Each task's initial state as `task_state` gives it (or the exception it raises), the
    states left to the worker made together (`members.initial_states`: the same numbers).

    Example:
        >>> import s2gen
        >>> from s2gen.ensemble.members import member_table
        >>> s = s2gen.load("double_pendulum")
        >>> p = make_payload(s, {}, "vi", T=0.1, table=member_table(s, 3, {"omega": 1e-10}))
        >>> tasks = [Task(j, 0.01, None, None, ()) for j in range(3)]
        >>> states = task_states(p, tasks)
        >>> all(np.array_equal(a[1], task_state(p, t)[1]) for a, t in zip(states, tasks))
        True
    """
    from .members import initial_states

    out: list[tuple[np.ndarray, np.ndarray] | Exception] = []
    left: list[int] = []
    for j, task in enumerate(tasks):
        if task.q0 is not None and task.omega0 is not None:
            out.append((task.q0, task.omega0))
        elif payload.table is None:
            out.append(ValueError(_NO_STATE.format(task.index)))
        else:
            out.append(ValueError())  # made below
            left.append(j)
    if left:
        table = payload.table
        try:
            q, w = initial_states(
                payload.system, table, [table.members[tasks[j].index] for j in left]
            )
        except Exception as exc:  # noqa: BLE001 (each task's outcome, raised by its caller)
            for j in left:
                out[j] = exc
        else:
            for row, j in enumerate(left):
                out[j] = (q[row], w[row])
    return out


def _model(payload: Payload) -> tuple[Model, float]:
    """This thread's loaded model of the payload's sources, and the seconds spent loading it
    now (0 when reused)."""
    models: OrderedDict[str, Any] = getattr(_local, "models", None) or OrderedDict()
    _local.models = models
    if payload.digest in models:
        models.move_to_end(payload.digest)
        return models[payload.digest], 0.0
    from s2gen.runtime.model import Model

    start = time.perf_counter()
    model = Model(payload.system, "c", files=payload.files)
    models[payload.digest] = model
    while len(models) > MODEL_CACHE:
        models.popitem(last=False)
    return model, time.perf_counter() - start


def sample_statistics(
    energy: np.ndarray, q: np.ndarray, valid: Sequence[int]
) -> tuple[list[float], list[float], list[float]]:
    """Per member j of a batch (energy (K, S), q (K, S, n, 3), valid[j] <= S samples valid):
    the mean and the largest |E - E0| and the largest | |q_i| - 1 | over its valid samples
    (NaN with none). Members whose samples are all valid are reduced together; the numbers
    do not depend on the batch (the same reductions, row by row).

    Example:
        >>> e = np.array([[1.0, 1.5, 2.0]])
        >>> q = np.zeros((1, 3, 1, 3)); q[..., 0] = 1.0
        >>> sample_statistics(e, q, [3]), sample_statistics(e, q, [2])[0]
        (([0.5], [1.0], [0.0]), [0.25])
    """
    count = len(valid)
    mean, high, unit = [math.nan] * count, [math.nan] * count, [math.nan] * count
    full = [j for j in range(count) if valid[j] == energy.shape[1] > 0]
    parts = [(full, energy.shape[1])]
    parts += [([j], valid[j]) for j in range(count) if 0 < valid[j] < energy.shape[1]]
    for rows, k in parts:
        if not rows:
            continue
        every = rows == list(range(count)) and k == energy.shape[1]
        e, qq = (energy, q) if every else (energy[rows, :k], q[rows, :k])  # views, not copies
        dev = np.abs(e - e[:, :1])
        # sqrt and x - 1 are monotone (correctly rounded): the largest | |q| - 1 | is at the
        # largest or the smallest |q|^2, the same number as taken sample by sample. |q|^2 is
        # summed in a fixed order, elementwise: a reduction (einsum) may group the three terms
        # differently for a batch's strided view than for one member's contiguous array
        sq = (qq[..., 0] * qq[..., 0] + qq[..., 1] * qq[..., 1]) + qq[..., 2] * qq[..., 2]
        lo, hi = np.sqrt(sq.min(axis=(1, 2))), np.sqrt(sq.max(axis=(1, 2)))
        u = np.maximum(np.abs(lo - 1.0), np.abs(hi - 1.0))
        for j, m, x, y in zip(rows, dev.mean(axis=1), dev.max(axis=1), u, strict=True):
            mean[j], high[j], unit[j] = float(m), float(x), float(y)
    return mean, high, unit


def thin(x: np.ndarray, every: int) -> np.ndarray:
    """The stored samples of a per-sample array: every `every`-th, from the first.

    The one place the stride is applied (on the worker, before sending): the member is
    integrated at every step so that its statistics (energy and unit-length errors) see every
    sample; only what is stored and sent is thinned.

    Example:
        >>> thin(np.arange(7), 3).tolist()
        [0, 3, 6]
    """
    return np.ascontiguousarray(x[::every])


def _worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def run_member(payload: Payload, task: Task) -> MemberResult:
    """Integrate one member and summarise it (never raises for a failed integration)."""
    from s2gen.runtime.diagnostics import EnergyDriftWarning
    from s2gen.runtime.trajectory import IntegrationError

    different = payload.identity.differences(identity())  # the fingerprint is cached
    if different:  # a worker that joined after the start, running other code or flags
        raise RuntimeError(f"worker {_worker_name()} runs {different}: refused")
    model, setup = _model(payload)
    q0, w0 = task_state(payload, task)
    status, message = 0, "ok"
    try:
        with warnings.catch_warnings():  # a member's drift is in its statistics (max_dE)
            warnings.simplefilter("ignore", EnergyDriftWarning)
            tr = model.integrate(
                payload.method,
                task.h,
                payload.T,
                q0=q0,
                omega0=w0,
                options=payload.options,
                params=dict(task.params),
            )
    except IntegrationError as exc:
        tr, status, message = exc.partial, int(exc.status), str(exc)
    k = len(tr.t)
    (mean_de,), (max_de,), (max_unit,) = sample_statistics(tr.energy[None], tr.q[None], [k])
    stats = tr.stats
    return MemberResult(
        index=task.index,
        status=status,
        message=message,
        t=thin(tr.t, payload.every),
        q=thin(tr.q, payload.every),
        omega=thin(tr.omega, payload.every),
        energy=thin(tr.energy, payload.every),
        samples=k,
        mean_dE=mean_de,
        max_dE=max_de,
        max_unit=max_unit,
        steps=int(stats.get("steps", max(k - 1, 0))),
        rejected=int(stats.get("rejected", 0)),
        gradient_evals=int(stats.get("gradient_evals", 0)),
        wall_time=float(tr.wall_time),
        setup_time=setup,
        worker=_worker_name(),
    )


def failed_task(task: Task, n: int, message: str) -> MemberResult:
    """The result recorded for a member whose task raised (status `TASK_ERROR`, no samples)."""
    empty = np.zeros((0, n, 3))
    return MemberResult(
        index=task.index,
        status=TASK_ERROR,
        message=message,
        t=np.zeros(0),
        q=empty,
        omega=empty,
        energy=np.zeros(0),
        samples=0,
        mean_dE=float("nan"),
        max_dE=float("nan"),
        max_unit=float("nan"),
        steps=0,
        rejected=0,
        gradient_evals=0,
        wall_time=0.0,
        setup_time=0.0,
        worker="",
    )
