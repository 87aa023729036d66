"""The store's chunks of many members: whatever order members arrive in, and wherever a run
stops, the store holds exactly the members it says it holds, each as integrated on its own
through the public API (`s2gen.compile(...).integrate`, not the ensemble's code)."""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_ensemble import _direct

import s2gen
from s2gen.ensemble import EnsembleStore, initial_state, member_table
from s2gen.ensemble import chunks as chunks_module
from s2gen.ensemble.chunks import MAX_MEMBERS_PER_CHUNK, members_per_chunk
from s2gen.ensemble.store import TRAJECTORIES
from s2gen.ensemble.worker import TASK_ERROR, Task, failed_task, make_payload, run_member

pytest.importorskip("zarr")


def _check(store: EnsembleStore, expected: list[dict[str, Any]], present: set[int]) -> None:
    """Members in `present` stored as integrated (NaN after their last sample), the others
    absent (status -1, no samples)."""
    assert set(np.flatnonzero(store.written()).tolist()) == present
    status = store.per_member()["status"]
    for i, e in enumerate(expected):
        for name in TRAJECTORIES:
            stored = np.asarray(store.array(name)[i])
            if i in present:
                k = len(e[name])
                assert np.array_equal(stored[:k], e[name]), (i, name)
                assert np.isnan(stored[k:]).all(), (i, name)
            else:
                assert np.isnan(stored).all(), (i, name)
        if i in present:
            assert status[i] == e["status"], i


def test_members_in_any_order_and_partial_flushes_fill_chunks_exactly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Nine members in chunks of two (forced small), one failing mid-run (three_bodies with a
    huge gamma meets a collision), one whose task raised: written in a shuffled order with a
    flush (as on a timer or an interrupt) between batches; after each flush exactly the
    members taken so far are present, and in the end all."""
    s = s2gen.load("three_bodies")
    table = member_table(s, 3, {"omega": 1e-12}, {"gamma": [1.0, 30.0, 300.0]}, T=0.5, h=0.01)
    samples = 51
    per_member = 8 * samples * 3 * s.n
    monkeypatch.setattr(chunks_module, "CHUNK_BYTES", 2 * per_member)
    assert members_per_chunk(samples, s.n) == 2
    store = EnsembleStore.create(tmp_path, table, s.n, samples, attrs={})
    assert store.array("q").chunks[0] == store.array("energy").chunks[0] == 2
    payload = make_payload(s, s2gen.generate(s, "c"), "vi", T=0.5, every=1)
    results = []
    for m in table.members:
        q0, w0 = initial_state(s, table, m)
        task = Task(m.index, m.h, q0, w0, m.params)
        results.append(
            failed_task(task, s.n, "RuntimeError: lost")
            if m.index == 4
            else run_member(payload, task)
        )
    expected = _direct(s, table, every=1)
    assert any(e["status"] != 0 for e in expected)  # a member that fails inside a chunk
    expected[4] = {
        "status": TASK_ERROR,
        **{name: np.asarray(getattr(results[4], name)) for name in TRAJECTORIES},
    }
    order = list(range(9))
    random.Random(7).shuffle(order)
    present: set[int] = set()
    for lo in range(0, 9, 2):
        batch = tuple(results[i] for i in order[lo : lo + 2])
        store.write_many(batch)
        present |= {r.index for r in batch}
        store.flush()
        _check(EnsembleStore.open(tmp_path), expected, present)
    store.consolidate()
    _check(EnsembleStore.open(tmp_path), expected, set(range(9)))


def test_chunks_hold_many_small_members_and_one_large_one() -> None:
    """Small members share a chunk (up to the cap); a member larger than the chunk budget has
    a chunk of its own; the budget is what it says."""
    assert members_per_chunk(samples=11, n=2) == MAX_MEMBERS_PER_CHUNK
    assert members_per_chunk(samples=10**4, n=642) == 1
    k = members_per_chunk(samples=1001, n=20)
    assert k * 8 * 1001 * 3 * 20 <= chunks_module.CHUNK_BYTES < (k + 1) * 8 * 1001 * 3 * 20
