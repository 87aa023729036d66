"""A batch of members through integrate_batch(): one C call, each member's result as
`worker.run_member` would give it.

Input: a `Payload` that carries the sources of the module with integrate_batch()
(`Payload.batch_files`: closed systems and a batched method, see
`s2gen.parts.batch`) and a batch of `Task`s with one step size. Output: their
`MemberResult`s, each equal to `run_member`'s for that member (its samples, energy and
statistics bit for bit: integrate_batch() is integrate() lane by lane; its status and message
by the same checks and texts as `s2gen.runtime.run`), except the timings: a member's wall time
is its share of the batch's call. A member whose inputs `run` would refuse (a non-unit q0, a
potential not finite at q0) is recorded as a task error with `run`'s message, as
`run_members` records it.

Example:
    >>> import s2gen
    >>> from s2gen.ensemble.worker import Task, make_payload
    >>> s = s2gen.load("four_pendula")
    >>> payload = make_payload(s, s2gen.generate(s, "c"), "vi", T=0.1, every=5,
    ...                        batch_files=s2gen.generate(s.with_batch(), "c"))
    >>> rs = run_batched(payload, (Task(0, 0.01, s.q0, s.omega0, ()),
    ...                            Task(1, 0.01, s.q0, s.omega0, (("g", 1.0),))))
    >>> [r.index for r in rs], [r.status for r in rs], rs[0].q.shape
    ([0, 1], [0, 0], (3, 4, 3))
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .worker import (
    MemberResult,
    Payload,
    Task,
    _model,
    _worker_name,
    failed_task,
    run_member,
    sample_statistics,
    task_states,
    thin,
)

__all__ = [
    "Packed",
    "pack",
    "run_batched",
    "run_members",
    "run_packed",
    "unpack",
    "warm_up",
]

_local = threading.local()


def _backend(payload: Payload) -> tuple[Any, float]:
    """This thread's loaded module with integrate_batch(), and the seconds spent loading it
    now (0 when reused): one per payload (keyed by its digest)."""
    from s2gen.runtime.c import CBackend

    cached = getattr(_local, "batch", None)
    if cached is not None and cached[0] == payload.digest:
        return cached[1], 0.0
    start = time.perf_counter()
    be = CBackend(payload.system.with_batch(), files=payload.batch_files)
    _local.batch = (payload.digest, be)
    return be, time.perf_counter() - start


def warm_up(payload: Payload) -> tuple[float, float]:
    """Ready this worker thread for the payload's members before the first of them: check the
    worker's identity (`admission.identity`, refused as a task would be), load the model
    `run_member` uses and, where the payload has one, the module with integrate_batch(), and
    import what running them needs; then time the payload table's first member through
    `run_member` (its result is dropped: the member's own task runs it). Returns the seconds
    the loads took and that member's integration time (0 when it failed, or without a
    table), which sets the batch size (`dispatch.batch_size_for`). Each member's result is
    the same with or without it (the members' tasks load whatever is not loaded yet); an
    ensemble runs it once per worker while it sets up, so that its members' phase does not
    pay for a fresh worker's imports and loads, nor wait for a first member to measure.

    Example:
        >>> import s2gen
        >>> from s2gen.ensemble.members import member_table
        >>> from s2gen.ensemble.worker import make_payload
        >>> s = s2gen.load("double_pendulum")
        >>> payload = make_payload(s, s2gen.generate(s, "c"), "vi", T=0.1,
        ...                        batch_files=s2gen.generate(s.with_batch(), "c"),
        ...                        table=member_table(s, 2, {"omega": 1e-10}, T=0.1))
        >>> seconds, member = warm_up(payload)
        >>> seconds >= 0.0, member > 0.0, getattr(_local, "batch")[0] == payload.digest
        (True, True, True)
    """
    start = time.perf_counter()
    # what running the members imports: now rather than by the first batch
    import s2gen.runtime.batch
    import s2gen.runtime.diagnostics
    import s2gen.runtime.inputs  # noqa: F401

    from . import members  # noqa: F401
    from .admission import identity

    different = payload.identity.differences(identity())
    if different:
        raise RuntimeError(f"worker {_worker_name()} runs {different}: refused")
    _model(payload)
    if payload.batch_files is not None:
        _backend(payload)
    seconds = time.perf_counter() - start
    if payload.table is None or not payload.table.members:
        return seconds, 0.0
    first = payload.table.members[0]
    try:
        r = run_member(payload, Task(first.index, first.h, None, None, first.params))
    except Exception:  # noqa: BLE001 (the member's own task records why)
        return seconds, 0.0
    return seconds, r.wall_time if r.status >= 0 else 0.0


def run_batched(payload: Payload, tasks: tuple[Task, ...]) -> tuple[MemberResult, ...] | None:
    """The batch's results through one integrate_batch() call, or None when the payload has
    no batched module or the members' step sizes differ (then `run_members` runs them one by
    one)."""
    from s2gen.methods import Status
    from s2gen.runtime import check_run, failure, nonfinite_energy
    from s2gen.runtime.batch import integrate_batch
    from s2gen.runtime.diagnostics import energy_scale, first_nonfinite
    from s2gen.runtime.inputs import initial_state, parameter_vector

    from .admission import identity

    steps = {t.h for t in tasks}
    if payload.batch_files is None or len(steps) != 1:
        return None
    different = payload.identity.differences(identity())
    if different:
        raise RuntimeError(f"worker {_worker_name()} runs {different}: refused")
    be, setup = _backend(payload)
    system, opts, method, h = payload.system, payload.options, payload.method, steps.pop()
    n = system.n
    out: dict[int, MemberResult] = {}
    ready: list[tuple[Task, np.ndarray, np.ndarray, np.ndarray]] = []
    try:  # the run's checks do not depend on the member: made once, raised for each
        nsteps, refused = check_run(system, method, h, payload.T, opts, 1), None
    except ValueError as exc:
        nsteps, refused = 0, exc
    states = task_states(payload, tasks)
    passes = _plain_states(states, n, opts.unit_tol)
    vectors: dict[tuple[tuple[str, float], ...], np.ndarray] = {}  # members share parameters
    for j, (task, state) in enumerate(zip(tasks, states, strict=True)):  # run's checks, in order
        try:
            p = vectors.get(task.params)
            if p is None:
                p = parameter_vector(system, parameter_vector(system, dict(task.params)))
                vectors[task.params] = p
            if refused is not None:
                raise refused
            if isinstance(state, Exception):
                raise state
            if passes[j]:  # initial_state would return them as they are
                q0, w0 = state
            else:
                q0, w0 = initial_state(system, *state, opts.unit_tol)
            # `energy_scale`'s checks (the gradient, V and the kinetic energy finite at t = 0)
            # run below, only for a member whose batch run failed or whose energy is not
            # finite: a non-finite gradient at q0 makes the first step's state non-finite
            # (IEEE inf and NaN propagate through every method's update), which the C reports,
            # so those are exactly the members the checks refuse
        except Exception as exc:  # noqa: BLE001 (the member's outcome, as run_members records it)
            out[task.index] = failed_task(task, n, f"{type(exc).__name__}: {exc}")
        else:
            ready.append((task, q0, w0, p))
    if ready:
        start = time.perf_counter()
        b = integrate_batch(
            be,
            method,
            h,
            nsteps,
            np.stack([r[1] for r in ready]),
            np.stack([r[2] for r in ready]),
            np.stack([r[3] for r in ready]),
            opts,
        )
        wall = (time.perf_counter() - start) / len(ready)
        assert b.energy is not None
        ends: list[tuple[Task, int, str, int] | None] = []
        recheck = (b.status != 0) | ~np.isfinite(b.energy).all(axis=1)  # see above
        for j, (task, q0, w0, p) in enumerate(ready):
            if recheck[j]:
                try:
                    energy_scale(be, q0, w0, p, True)
                except ValueError as exc:
                    out[task.index] = failed_task(task, n, f"{type(exc).__name__}: {exc}")
                    ends.append(None)
                    continue
            status = int(b.status[j])
            k = int(b.stats["fail_step"][j]) if status else len(b.t)
            why = Status(status).message if status in Status._value2member_map_ else str(status)
            bad = first_nonfinite(b.energy[j], k) if recheck[j] else None
            if bad is not None:
                k, status, why = bad, int(Status.NONFINITE), nonfinite_energy(b.t, k)
            ends.append((task, status, failure(method, "c", b.t, k, why) if status else "ok", k))
        stats = sample_statistics(b.energy, b.q, [end[3] if end else 0 for end in ends])
        for j, end in enumerate(ends):
            if end is None:
                continue
            task, status, message, k = end
            numbers = (stats[0][j], stats[1][j], stats[2][j])
            out[task.index] = _result(payload, task, status, message, b, j, k, numbers, wall, setup)
            setup = 0.0
    return tuple(out[t.index] for t in tasks)


def _plain_states(states: Sequence[Any], n: int, unit_tol: float) -> np.ndarray:
    """Which of the states (q0, omega0) `runtime.inputs.initial_state` would take as they are:
    float arrays of shape (n, 3), finite, each |q_i| within unit_tol of 1 (its own test on the
    same numbers), judged for the batch at once; the others go through it one by one (for
    its conversions and its message).

    Example:
        >>> q = np.array([[0.0, 0.0, 1.0]])
        >>> _plain_states([(q, q), (2 * q, q), ValueError()], 1, 1e-12).tolist()
        [True, False, False]
    """
    shaped = [
        j
        for j, s in enumerate(states)
        if isinstance(s, tuple)
        and all(isinstance(a, np.ndarray) and a.dtype == float and a.shape == (n, 3) for a in s)
    ]
    out = np.zeros(len(states), dtype=bool)
    if shaped:
        q = np.stack([states[j][0] for j in shaped])
        w = np.stack([states[j][1] for j in shaped])
        ok = np.isfinite(q).all(axis=(1, 2)) & np.isfinite(w).all(axis=(1, 2))
        if unit_tol > 0.0:
            ok &= (np.abs(np.linalg.norm(q, axis=2) - 1.0) <= unit_tol).all(axis=1)
        out[shaped] = ok
    return out


def _result(
    payload: Payload,
    task: Task,
    status: int,
    message: str,
    b: Any,
    j: int,
    k: int,
    numbers: tuple[float, float, float],
    wall: float,
    setup: float,
) -> MemberResult:
    """Member j of batch b with its k valid samples and `sample_statistics`' numbers (mean
    and largest |E - E0|, largest unit-length error), summarised as `run_member` does."""
    t, q, w, e = b.t[:k], b.q[j, :k], b.omega[j, :k], b.energy[j, :k]
    mean_de, max_de, max_unit = numbers
    return MemberResult(
        index=task.index,
        status=status,
        message=message,
        t=thin(t, payload.every),
        q=thin(q, payload.every),
        omega=thin(w, payload.every),
        energy=thin(e, payload.every),
        samples=k,
        mean_dE=mean_de,
        max_dE=max_de,
        max_unit=max_unit,
        steps=int(b.stats["steps"][j]),
        rejected=int(b.stats["rejected"][j]),
        gradient_evals=int(b.stats["gradient_evals"][j]),
        wall_time=wall,
        setup_time=setup,
        worker=_worker_name(),
    )


def run_members(payload: Payload, tasks: tuple[Task, ...]) -> tuple[MemberResult, ...]:
    """A batch of members: through one integrate_batch() call when the payload carries
    that module and the members share their step (`batched.run_batched`), else one after
    another with this worker's loaded model; each one's result as `run_member` gives it
    (timings aside), a member whose task raises recorded as `failed_task` (the others go
    on). One Dask task per batch carries its members' inputs and results.

    Example:
        >>> import s2gen
        >>> from s2gen.ensemble.worker import Task, make_payload
        >>> s = s2gen.load("double_pendulum")
        >>> payload = make_payload(s, s2gen.generate(s, "c"), "vi", T=0.1, every=5)
        >>> rs = run_members(payload, (Task(0, 0.01, s.q0, s.omega0, ()),
        ...                            Task(1, 0.01, s.q0, s.omega0, (("g", 1.0),))))
        >>> [r.index for r in rs], [r.status for r in rs]
        ([0, 1], [0, 0])
    """
    if len(tasks) > 1 and payload.batch_files is not None:
        batched = run_batched(payload, tasks)
        if batched is not None:
            return batched
    out = []
    for task in tasks:
        try:
            out.append(run_member(payload, task))
        except Exception as exc:  # noqa: BLE001 (the member's outcome; the batch goes on)
            out.append(failed_task(task, payload.system.n, f"{type(exc).__name__}: {exc}"))
    return tuple(out)


@dataclass(frozen=True)
class Packed:
    """A batch of `MemberResult`s as a few arrays, the form results travel in from a worker:
    each member's samples one after another along the first axis of `t`, `q`, `omega`,
    `energy` (member j's from ``starts[j]`` to ``starts[j + 1]``), its numbers in one column
    each (`columns`, by `MemberResult` field) and its messages, workers and field values that
    are not numbers in `text`. A handful of buffers per batch instead of four arrays and a
    dozen objects per member: what the transport (pickle protocol 5, a frame per buffer)
    costs per member shrinks accordingly."""

    starts: np.ndarray
    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray
    columns: dict[str, np.ndarray]
    text: dict[str, tuple[str, ...]]


#: The `MemberResult` fields that `Packed` keeps as columns: integers, then floats.
_INTEGERS = ("index", "status", "samples", "steps", "rejected", "gradient_evals")
_FLOATS = ("mean_dE", "max_dE", "max_unit", "wall_time", "setup_time")


def pack(results: Sequence[MemberResult], n: int) -> Packed:
    """`results` (of a system of `n` bodies) as one `Packed` record; `unpack` gives them back
    equal field by field, bit for bit.

    Example:
        >>> from s2gen.ensemble.worker import Task, failed_task
        >>> r = failed_task(Task(7, 0.1, None, None, ()), 2, "why")
        >>> back = unpack(pack([r, r], 2))
        >>> [x.index for x in back], back[1].message, back[0].q.shape
        ([7, 7], 'why', (0, 2, 3))
    """
    lengths = [len(r.t) for r in results]
    starts = np.concatenate([[0], np.cumsum(lengths, dtype=np.int64)])

    def joined(name: str, shape: tuple[int, ...]) -> np.ndarray:
        parts = [getattr(r, name) for r in results]
        return np.concatenate(parts) if parts else np.zeros((0, *shape))

    return Packed(
        starts=starts,
        t=joined("t", ()),
        q=joined("q", (n, 3)),
        omega=joined("omega", (n, 3)),
        energy=joined("energy", ()),
        columns={
            **{k: np.array([getattr(r, k) for r in results], dtype=np.int64) for k in _INTEGERS},
            **{k: np.array([getattr(r, k) for r in results], dtype=float) for k in _FLOATS},
        },
        text={k: tuple(getattr(r, k) for r in results) for k in ("message", "worker")},
    )


def unpack(packed: Packed) -> tuple[MemberResult, ...]:
    """The `MemberResult`s `pack` was given (their arrays are views of the packed ones)."""
    out = []
    for j in range(len(packed.starts) - 1):
        a, b = int(packed.starts[j]), int(packed.starts[j + 1])
        numbers: dict[str, Any] = {k: int(packed.columns[k][j]) for k in _INTEGERS}
        numbers.update({k: float(packed.columns[k][j]) for k in _FLOATS})
        out.append(
            MemberResult(
                **numbers,
                message=packed.text["message"][j],
                worker=packed.text["worker"][j],
                t=packed.t[a:b],
                q=packed.q[a:b],
                omega=packed.omega[a:b],
                energy=packed.energy[a:b],
            )
        )
    return tuple(out)


def run_packed(payload: Payload, tasks: tuple[Task, ...]) -> Packed:
    """`run_members`' results, packed for the trip to the client (`pack`)."""
    return pack(run_members(payload, tasks), payload.system.n)
