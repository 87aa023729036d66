"""Members' samples gathered into the store's chunks, so that each chunk is written once.

Zarr pays a fixed cost per chunk written (about 1.5 ms per member and array when every
member was its own chunk: more than a small member's integration). The store's trajectory
arrays therefore hold many members per chunk (`members_per_chunk`: as many as fit in
`CHUNK_BYTES` of ``q``, at most `MAX_MEMBERS_PER_CHUNK`), and the client gathers results
here until a chunk is complete, then writes it in one assignment per array (no read of the
chunk first). Members arrive in any order; an incomplete chunk is written as far as it goes
when the store flushes (every `s2gen.ensemble.store.FLUSH_SECONDS`, at the end and on
interrupt), and kept here until it completes.

Input: the member count, the chunk size and `MemberResult`s. Output: blocks of rows (member,
sample, ...) with NaN after a member's last valid sample.

Example:
    >>> members_per_chunk(samples=11, n=2)
    1024
    >>> members_per_chunk(samples=10**5, n=642)
    1
    >>> buf = ChunkBuffer(count=5, size=2)
    >>> buf.members(2)
    range(4, 5)
    >>> from s2gen.ensemble.worker import Task, failed_task
    >>> r = [failed_task(Task(i, 0.01, None, None, ()), 2, "x") for i in range(5)]
    >>> buf.add(r[4]), buf.add(r[1]), buf.add(r[0])
    (2, None, 0)
    >>> rows([r[3]], "q", samples=2).shape
    (1, 2, 2, 3)
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from .worker import MemberResult

__all__ = ["CHUNK_BYTES", "MAX_MEMBERS_PER_CHUNK", "ChunkBuffer", "members_per_chunk"]

#: Uncompressed bytes of ``q`` per chunk that set the members per chunk (4 MiB: large enough
#: that Zarr's per-chunk cost is small against the bytes, small enough to hold a few chunks
#: in memory while members arrive out of order).
CHUNK_BYTES = 4 * 2**20
#: At most this many members per chunk.
MAX_MEMBERS_PER_CHUNK = 1024


def members_per_chunk(samples: int, n: int) -> int:
    """Members per trajectory chunk for `samples` stored samples of `n` bodies."""
    per_member = 8 * max(1, samples) * 3 * max(1, n)
    return max(1, min(MAX_MEMBERS_PER_CHUNK, CHUNK_BYTES // per_member))


class ChunkBuffer:
    """Results held by chunk (member index // size) until the chunk is complete."""

    def __init__(self, count: int, size: int) -> None:
        self.count, self.size = count, size
        self._open: dict[int, dict[int, MemberResult]] = {}
        self._dirty: set[int] = set()  # incomplete chunks that took a member since `dirty()`

    def members(self, chunk: int) -> range:
        """The member indices of `chunk`."""
        return range(chunk * self.size, min(self.count, (chunk + 1) * self.size))

    def add(self, result: MemberResult) -> int | None:
        """Hold `result`; the index of its chunk if that chunk is now complete, else None."""
        chunk = result.index // self.size
        held = self._open.setdefault(chunk, {})
        held[result.index] = result
        if len(held) == len(self.members(chunk)):
            return chunk
        self._dirty.add(chunk)
        return None

    def pop(self, chunk: int) -> dict[int, MemberResult]:
        """The results of `chunk`, no longer held."""
        self._dirty.discard(chunk)
        return self._open.pop(chunk)

    def dirty(self) -> Iterator[dict[int, MemberResult]]:
        """The results of each incomplete chunk that took a member since the last call (still
        held)."""
        chunks, self._dirty = sorted(self._dirty), set()
        for c in chunks:
            yield self._open[c]


def rows(results: list[MemberResult], name: str, samples: int) -> np.ndarray:
    """Array `name` of consecutive members' `results` as one block (member, sample, ...), NaN
    after each member's last valid sample."""
    first = np.asarray(getattr(results[0], name))
    block = np.full((len(results), samples, *first.shape[1:]), np.nan)
    for j, r in enumerate(results):
        values = np.asarray(getattr(r, name))
        block[j, : len(values)] = values
    return block


def runs(results: dict[int, MemberResult]) -> list[list[MemberResult]]:
    """`results` split into runs of consecutive member indices, in order."""
    out: list[list[MemberResult]] = []
    for i in sorted(results):
        if out and out[-1][-1].index + 1 == i:
            out[-1].append(results[i])
        else:
            out.append([results[i]])
    return out
