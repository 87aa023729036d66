"""The on-disk store of an ensemble: one chunked Zarr (v3) group, written member by member.

Input: a `MemberTable`, the system's size and the stored sample count (`create`), then one
`MemberResult` at a time (`write`). Output: the folder ``ensemble.zarr`` that holds

- ``q``, ``omega``: (member, sample, body, component), float64, chunks of many members
  (`s2gen.ensemble.chunks.members_per_chunk`), NaN after a member's last valid sample (a
  failed member keeps its samples up to the failure);
- ``energy``, ``t``: (member, sample), likewise;
- per-member statistics over all valid samples (not only the stored ones), dimension member:
  ``mean_dE``, ``max_dE`` (|E - E0|), ``max_unit`` (max | |q_i| - 1 |), ``samples`` (valid
  samples), ``steps``, ``rejected``, ``gradient_evals``, ``status`` (0 ok, a
  `s2gen.methods.Status` code, -2 the task raised, -1 not written), ``wall_time`` (the
  integration), ``setup_time`` (loading the model on that worker, 0 when reused);
- coordinates, dimension member: ``member``, ``point`` (sweep point), ``replica`` (0 = the
  unperturbed reference), ``seed`` (the perturbation of member i is drawn from
  ``numpy.random.default_rng([seed[i], replica[i]])``), ``perturb_q``, ``perturb_omega``
  (relative sizes, 0 for the reference), ``h`` and ``param_NAME`` per swept parameter;
  ``body`` (1-based) and ``component`` (0..2);
- group attributes under "s2gen": system, method, T, every, options, perturbations, sweeps,
  status messages, the generator version and the command.

Every array names its dimensions (Zarr v3 ``dimension_names``; ``xarray.open_zarr`` reads the
group as a Dataset). Trajectories are gathered by chunk and each chunk written once, when
its last member arrives (`s2gen.ensemble.chunks`); the small per-member statistics are
buffered too. `flush` (at least every `FLUSH_SECONDS`, at the end and on interrupt) writes
the incomplete chunks as far as they go, then the statistics, ``status`` last, so a member
whose status is -1 is absent, whatever its samples say.
A complete store has its metadata consolidated (`consolidate`): ``xarray.open_zarr`` opens it
in one read, without warning.

Example:
    >>> import tempfile, s2gen
    >>> from s2gen.ensemble.members import member_table
    >>> s = s2gen.load("double_pendulum")
    >>> with tempfile.TemporaryDirectory() as d:
    ...     st = EnsembleStore.create(d, member_table(s), n=2, samples=11, attrs={})
    ...     st.array("q").shape, st.dims("q")
    ((1, 11, 2, 3), ('member', 'sample', 'body', 'component'))
"""

from __future__ import annotations

import shutil
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .chunks import ChunkBuffer, members_per_chunk, rows, runs
from .members import EnsembleError, MemberTable
from .requirements import require
from .worker import TASK_ERROR, MemberResult

__all__ = [
    "COORDINATES",
    "FLUSH_SECONDS",
    "MAX_STORE_BYTES",
    "NOT_WRITTEN",
    "STATISTICS",
    "STORE_NAME",
    "TRAJECTORIES",
    "EnsembleStore",
    "check_store_size",
    "store_bytes",
]

#: The store's folder name inside an ensemble's output folder.
STORE_NAME = "ensemble.zarr"
#: Status of a member not (yet) written.
NOT_WRITTEN = -1
#: Buffered statistics are written at least this often while results arrive.
FLUSH_SECONDS = 5.0
#: Per-sample arrays and their dimensions.
TRAJECTORIES = {
    "q": ("member", "sample", "body", "component"),
    "omega": ("member", "sample", "body", "component"),
    "energy": ("member", "sample"),
    "t": ("member", "sample"),
}
#: Per-member statistics: name -> (dtype, fill value); `status` is written last.
STATISTICS: dict[str, tuple[str, float | int]] = {
    "mean_dE": ("f8", np.nan),
    "max_dE": ("f8", np.nan),
    "max_unit": ("f8", np.nan),
    "samples": ("i8", 0),
    "steps": ("i8", 0),
    "rejected": ("i8", 0),
    "gradient_evals": ("i8", 0),
    "wall_time": ("f8", np.nan),
    "setup_time": ("f8", np.nan),
    "status": ("i4", NOT_WRITTEN),
}
#: Per-member coordinates every store has (plus param_NAME per swept parameter).
COORDINATES = ("member", "point", "replica", "seed", "perturb_q", "perturb_omega", "h")
#: Largest store an ensemble may write, in bytes before compression (1 TiB): checked, from
#: the member and sample counts, before the store or any member is made.
MAX_STORE_BYTES = 2**40
_MEMBER_CHUNK = 1024


def _codec() -> Any:
    """Blosc LZ4 with byte shuffle: the fastest lossless codec we measured on trajectories
    (9 ms per 7 MB member against 18 ms for Zarr's default zstd, 13 % smaller than raw)."""
    from zarr.codecs import BloscCodec

    return BloscCodec(cname="lz4", clevel=5, shuffle="shuffle")


def _coordinates(table: MemberTable) -> dict[str, np.ndarray]:
    ms = table.members
    coords = {
        "member": np.array([m.index for m in ms], dtype="i8"),
        "point": np.array([m.point for m in ms], dtype="i8"),
        "replica": np.array([m.replica for m in ms], dtype="i8"),
        "seed": np.full(len(ms), table.seed, dtype="i8"),
        "perturb_q": np.array([table.size("q") if m.perturbed else 0.0 for m in ms]),
        "perturb_omega": np.array([table.size("omega") if m.perturbed else 0.0 for m in ms]),
        "h": np.array([m.h for m in ms]),
    }
    for sweep in table.sweeps:
        if sweep.name != "h":
            coords[f"param_{sweep.name}"] = np.array([dict(m.params)[sweep.name] for m in ms])
    return coords


def store_bytes(members: int, samples: int, n: int) -> int:
    """Bytes of a store before compression: q and omega (3 n doubles per sample), energy and
    t (one each), per-member statistics and coordinates (at most 32 eight-byte values).

    Example:
        >>> store_bytes(members=4, samples=11, n=2)
        5952
    """
    return 8 * members * (samples * (6 * n + 2) + 32)


def check_store_size(members: int, samples: int, n: int) -> None:
    """Refuse (`EnsembleError`, one line) a store larger than `MAX_STORE_BYTES`.

    Example:
        >>> check_store_size(10**6, 10**6, 2)
        Traceback (most recent call last):
        ...
        s2gen.ensemble.members.EnsembleError: the store would hold 112 TB (1000000 members x 1000000 samples x 2 bodies) before compression, more than the limit of 1.1 TB; store fewer samples (every), members or a shorter T
    """
    need = store_bytes(members, samples, n)
    if need > MAX_STORE_BYTES:
        raise EnsembleError(
            f"the store would hold {need / 1e12:.3g} TB ({members} members x {samples} samples x "
            f"{n} bodies) before compression, more than the limit of "
            f"{MAX_STORE_BYTES / 1e12:.2g} TB; store fewer samples (every), members or a "
            "shorter T"
        )


class EnsembleStore:
    """An ensemble's Zarr group: create it, write members into it, read it back."""

    def __init__(self, path: Path, group: Any) -> None:
        self.path = path
        self.group = group
        self._arrays: dict[str, Any] = {}  # opened once: each lookup re-reads its metadata
        self._pending: dict[int, dict[str, Any]] = {}  # statistics only, never samples
        self._chunks: ChunkBuffer | None = None  # samples, by chunk (made on first write)
        self._errors: dict[str, str] = {}
        self._last_flush = time.monotonic()

    # ----------------------------------------------------------------------------- creation
    @classmethod
    def create(
        cls,
        folder: str | Path,
        table: MemberTable,
        n: int,
        samples: int,
        attrs: dict[str, Any],
        overwrite: bool = False,
    ) -> EnsembleStore:
        """A new store ``folder/ensemble.zarr`` for `table` (refuses to replace one unless
        `overwrite`)."""
        require("zarr")
        import zarr

        path = Path(folder) / STORE_NAME
        if path.exists():
            if not overwrite:
                raise EnsembleError(f"{path} exists; choose another --out or pass --overwrite")
            shutil.rmtree(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        group = zarr.open_group(str(path), mode="w")
        count = len(table)
        per_chunk = members_per_chunk(samples, n)
        for name, dims in TRAJECTORIES.items():
            shape = (count, samples, n, 3)[: len(dims)]
            group.create_array(
                name,
                shape=shape,
                chunks=(per_chunk, *shape[1:]),
                dtype="f8",
                fill_value=np.nan,
                compressors=_codec(),
                dimension_names=list(dims),
            )
        chunk = (min(count, _MEMBER_CHUNK),)
        for name, (dtype, fill) in STATISTICS.items():
            group.create_array(
                name,
                shape=(count,),
                chunks=chunk,
                dtype=dtype,
                fill_value=fill,
                dimension_names=["member"],
            )
        coords = _coordinates(table)
        coords_small = {"body": np.arange(1, n + 1, dtype="i8"), "component": np.arange(3)}
        for name, values in {**coords, **coords_small}.items():
            dim = name if name in coords_small else "member"
            arr = group.create_array(
                name,
                shape=values.shape,
                chunks=values.shape if dim != "member" else chunk,
                dtype=values.dtype,
                dimension_names=[dim],
            )
            arr[:] = values
        coord_names = " ".join(n for n in coords if n != "member")
        for name in (*TRAJECTORIES, *STATISTICS):
            group[name].attrs["coordinates"] = coord_names
        group.attrs["s2gen"] = attrs
        return cls(path, group)

    @classmethod
    def open(cls, path: str | Path, mode: Literal["r", "r+"] = "r") -> EnsembleStore:
        """Open an existing store (the ``ensemble.zarr`` folder or the folder holding it)."""
        require("zarr")
        import zarr

        p = Path(path)
        if p.name != STORE_NAME and (p / STORE_NAME).exists():
            p = p / STORE_NAME
        if not p.exists():
            raise EnsembleError(f"no ensemble store at {p}")
        return cls(p, zarr.open_group(str(p), mode=mode))

    # ------------------------------------------------------------------------------ writing
    def write(self, result: MemberResult) -> None:
        """Take a member's results: its samples are written with its chunk, its statistics
        buffered (both flushed every `FLUSH_SECONDS`, or by `flush`)."""
        self.write_many((result,))

    def write_many(self, results: tuple[MemberResult, ...]) -> None:
        """Take a batch of members as `write` takes one: each chunk they complete is written
        in one assignment per array."""
        chunks = self._buffer()
        for r in results:
            done = chunks.add(r)
            if done is not None:
                held = chunks.pop(done)
                self._write_rows([held[i] for i in chunks.members(done)])
            self._pending[r.index] = {name: getattr(r, name) for name in STATISTICS}
            if r.status == TASK_ERROR:
                self._errors[str(r.index)] = r.message
        if time.monotonic() - self._last_flush >= FLUSH_SECONDS:
            self.flush()

    def _buffer(self) -> ChunkBuffer:
        if self._chunks is None:
            q = self.array("q")
            self._chunks = ChunkBuffer(q.shape[0], q.chunks[0])
        return self._chunks

    def _write_rows(self, results: list[MemberResult]) -> None:
        """Consecutive members' samples, one assignment per array."""
        lo, samples = results[0].index, self.array("t").shape[1]
        for name in TRAJECTORIES:
            self.array(name)[lo : lo + len(results)] = rows(results, name, samples)

    def flush(self) -> None:
        """Write the incomplete chunks' samples as far as they go (they stay held until
        complete), then the buffered statistics (``status`` last)."""
        if self._chunks is not None:
            for held in self._chunks.dirty():
                for run in runs(held):
                    self._write_rows(run)
        if not self._pending:
            return
        idx = np.array(sorted(self._pending))
        rows = [self._pending[i] for i in idx]
        if self._errors:  # messages before statuses: a member marked -2 has its message
            meta = dict(self.group.attrs["s2gen"])
            meta["task_errors"] = {**meta.get("task_errors", {}), **self._errors}
            self.group.attrs["s2gen"] = meta
            self._errors.clear()
        for name, (dtype, _) in STATISTICS.items():
            values = np.array([r[name] for r in rows], dtype=dtype)
            self.array(name).set_orthogonal_selection((idx,), values)
        self._pending.clear()
        self._last_flush = time.monotonic()

    def consolidate(self) -> None:
        """Write the group's metadata into one document, so that readers (``xarray.open_zarr``)
        open the store in one read and without a warning. Called once the store is complete."""
        import zarr

        self.flush()
        with warnings.catch_warnings():  # zarr 3 notes that v3 consolidation is its extension
            warnings.filterwarnings("ignore", message="Consolidated metadata is currently not")
            zarr.consolidate_metadata(str(self.path))

    # ------------------------------------------------------------------------------ reading
    def array(self, name: str) -> Any:
        """The Zarr array `name` (index it to read)."""
        if name not in self._arrays:
            self._arrays[name] = self.group[name]
        return self._arrays[name]

    def dims(self, name: str) -> tuple[str, ...]:
        """The dimension names of array `name`."""
        return tuple(self.array(name).metadata.dimension_names)

    @property
    def attrs(self) -> dict[str, Any]:
        """The ensemble's settings (group attribute "s2gen")."""
        return dict(self.group.attrs["s2gen"])

    def names(self) -> list[str]:
        """Every array in the store."""
        return sorted(self.group.array_keys())

    def per_member(self) -> dict[str, np.ndarray]:
        """Every per-member array (statistics and coordinates), read whole (small)."""
        return {
            name: np.asarray(self.array(name)[:])
            for name in self.names()
            if self.dims(name) == ("member",)
        }

    def member(self, i: int, names: tuple[str, ...] = tuple(TRAJECTORIES)) -> dict[str, Any]:
        """The stored samples of member i (NaN after its last valid sample)."""
        return {name: np.asarray(self.array(name)[i]) for name in names}

    def members(
        self, indices: np.ndarray, names: tuple[str, ...] = tuple(TRAJECTORIES)
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """(i, `member(i, names)`) for each index in `indices` (ascending), read one chunk at a
        time: reading members one by one would decompress a chunk once per member."""
        idx = np.unique(np.asarray(indices, dtype=int))
        size = self.array(names[0]).chunks[0]
        for c in np.unique(idx // size):
            sel = idx[(idx >= c * size) & (idx < (c + 1) * size)]
            lo = int(sel[0])
            block = {name: np.asarray(self.array(name)[lo : int(sel[-1]) + 1]) for name in names}
            for i in sel:
                yield int(i), {name: block[name][i - lo] for name in names}

    def written(self) -> np.ndarray:
        """Boolean mask of the members present (status written)."""
        return np.asarray(self.array("status")[:]) != NOT_WRITTEN
