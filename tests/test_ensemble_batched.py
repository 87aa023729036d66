"""A batch of members through integrate_batch() gives each member what it gets alone.

`run_members` runs a batch in one integrate_batch() call, checks its members' inputs together
(the run's checks once, the initial states made together, the energy's check only where the
batch's energy at t = 0 is not finite) and packs the results for the trip to the client.
Compared here, member by member and bit for bit, with `run_member` (one `Model.integrate`
each, the path every check of `s2gen.runtime.run` was written for) on a batch that mixes
members that run with members each check refuses; and through `pack` / `unpack`.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

import numpy as np
import pytest

import s2gen
from s2gen.ensemble.batched import pack, run_members, unpack
from s2gen.ensemble.worker import MemberResult, Task, failed_task, make_payload, run_member

#: Fields that time the run or name where it ran: not part of a member's outcome.
_TIMINGS = {"wall_time", "setup_time", "worker"}


def _system() -> Any:
    """Two bodies under gravity-like forces, a pair term log(1 + qi.qj), which is -inf (its
    gradient infinite) when the bodies are antipodal, and sqrt(1 - q1[2]), finite at the
    pole q1 = e3 where its gradient is not."""
    return s2gen.define(
        name="pair_log",
        bodies=2,
        parameters={"m": 1.0, "k": 1.0, "a": 0.1},
        diagonal=["m", "m"],
        potential="k*(q1[2] + q2[2]) + a*log(1 + q1[0]*q2[0] + q1[1]*q2[1] + q1[2]*q2[2])"
        " + a*sqrt(1 - q1[2])",
        initial_q=[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        initial_omega=[[0.0, 0.3, 0.0], [0.2, 0.0, 0.1]],
    )


def _alone(payload: Any, task: Task) -> MemberResult:
    try:
        return run_member(payload, task)
    except Exception as exc:  # noqa: BLE001 (recorded as the ensemble records it)
        return failed_task(task, payload.system.n, f"{type(exc).__name__}: {exc}")


def _assert_same(a: MemberResult, b: MemberResult) -> None:
    for f in fields(MemberResult):
        if f.name in _TIMINGS:
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert x.shape == y.shape, f.name
            assert np.array_equal(x.view(np.uint64), y.view(np.uint64)), f.name
        elif isinstance(x, float) and np.isnan(x):
            assert np.isnan(y), f.name
        else:
            assert x == y, f.name


def test_a_mixed_batch_equals_its_members_run_alone() -> None:
    s = _system()
    payload = make_payload(
        s, s2gen.generate(s, "c"), "vi", T=0.5, every=5,
        batch_files=s2gen.generate(s.with_batch(), "c"),
    )  # fmt: skip
    q0, w0 = np.array(s.q0, dtype=float), np.array(s.omega0, dtype=float)
    antipodal = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    fast = w0 * 1e160  # finite, but its kinetic energy overflows: the energy's own check
    tasks = (
        Task(0, 0.01, q0, w0, ()),
        Task(1, 0.01, antipodal, np.zeros((2, 3)), ()),  # the gradient is not finite
        Task(2, 0.01, q0, fast, ()),  # refused by the deferred energy check
        Task(3, 0.01, 1.5 * q0, w0, ()),  # not unit length
        Task(4, 0.01, q0, w0, (("k", 4.0),)),
        Task(5, 0.01, q0, w0, (("nope", 1.0),)),  # unknown parameter
        Task(6, 0.01, q0, -w0, (("a", 0.0),)),
        Task(7, 0.01, np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), w0, ()),  # V finite, dV not
    )
    batched = run_members(payload, tasks)
    alone = [_alone(payload, t) for t in tasks]
    assert [r.index for r in batched] == list(range(8))
    assert [r.status for r in alone] == [0, -2, -2, -2, 0, -2, 0, -2]
    assert "gradient of V on body 1 is not finite" in alone[1].message
    assert "kinetic energy is not finite" in alone[2].message
    assert "gradient of V on body 1 is not finite" in alone[7].message
    for a, b in zip(batched, alone, strict=True):
        _assert_same(a, b)
    for a, b in zip(unpack(pack(batched, s.n)), batched, strict=True):
        _assert_same(a, b)
        assert (a.wall_time, a.setup_time, a.worker) == (b.wall_time, b.setup_time, b.worker)


@pytest.mark.parametrize("count", [0, 1])
def test_pack_of_few_members(count: int) -> None:
    r = failed_task(Task(3, 0.1, None, None, ()), 4, "why")
    back = unpack(pack([r] * count, 4))
    assert len(back) == count
    for a in back:
        _assert_same(a, r)


def test_a_batch_of_perturbed_members_keeps_their_statistics() -> None:
    """64 perturbed double-pendulum members from the ensemble's table: each member's
    statistics (mean and largest energy error, largest unit-length error) equal those of the
    member run alone, bit for bit, although the batch reduces them over a strided view of
    the batch's arrays (a reduction that regrouped |q|^2 changed max_unit by an ulp for 5 of
    these members)."""
    from s2gen.ensemble.members import member_table

    s = s2gen.load("double_pendulum")
    table = member_table(s, 64, {"omega": 1e-3}, None, 0, None, 2.0)
    payload = make_payload(
        s, s2gen.generate(s, "c"), "vi", T=2.0, every=10,
        batch_files=s2gen.generate(s.with_batch(), "c"), table=table,
    )  # fmt: skip
    tasks = tuple(Task(m.index, m.h, None, None, m.params) for m in table.members)
    for batched, task in zip(run_members(payload, tasks), tasks, strict=True):
        _assert_same(batched, run_member(payload, task))
