"""Data and member lists read from files: a [data] or [inertia.data] entry, a term's data
entry or its list of bodies or pairs, when it names a file.

Input: the spec's [data] and [inertia] tables and its term tables ([[potential.body]],
[[potential.pair]], [[forces.body]], [[forces.pair]]) as TOML read them, the body count, the
folder of the spec file (None for spec text with no file) and the spec's origin. Output: the
same tables with each ``{ file = "..." }`` entry replaced by the file's values: data as a
float array of shape (rows,) (one number per row) or (rows, 3) (one 3-vector per row), a
member list as whole numbers of shape (rows,) (bodies) or (rows, 2) (pairs); or a one-line
`SpecError` naming the key and the file. Files are ``.npy`` (read with
``numpy.load(allow_pickle=False)``), ``.txt`` (numbers separated by spaces) or ``.csv``
(separated by commas), one row per body or member; a relative path is relative to the spec's
folder::

    [data]
    charge = { file = "charges.npy" }     # shape (n,)
    offset = { file = "offsets.csv" }     # n rows of 3 numbers

    [[potential.pair]]
    V = "k/norm(qi - qj)"
    pairs = { file = "bonds.csv" }        # one pair i, j (1-based) per line
    data = { k = { file = "k.txt" } }     # one number per pair

The values then go through the same checks as values written inline, so a spec reads the
same numbers (and has the same `System.spec_digest`) either way; the digest hashes the values,
so it changes when a file's content changes.

Example:
    >>> read_data_files({"c": [1.0, 2.0]}, 2, None, "s", "[data]")
    {'c': [1.0, 2.0]}
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from s2gen.errors import SpecError, shown
from s2gen.spec.tables import _key

__all__ = ["read_data_files", "read_term_files"]

#: The file suffixes a datum may name, and the column separator of the text ones.
SUFFIXES = {".npy": None, ".txt": None, ".csv": ","}


def read_data_files(
    table: Any, n: Any, folder: Path | None, origin: str, label: str, per: str = "body"
) -> Any:
    """`table` (a [data]-like table, name = values) with the entries that name a file read
    into arrays; anything else is returned as it is, for the usual checks. `label` names the
    table in messages ("[data]" or "[inertia] data."); `n` is the number of rows asked for
    when known (the body count; None for a term's data, whose own checks count its members);
    `per` names a row in messages.

    Example:
        >>> import tempfile
        >>> folder = Path(tempfile.mkdtemp())
        >>> np.save(folder / "c.npy", np.array([1.0, -1.0, 0.5]))
        >>> read_data_files({"c": {"file": "c.npy"}}, 3, folder, "s.toml", "[data]")["c"]
        array([ 1. , -1. ,  0.5])
    """
    if not isinstance(table, Mapping) or not any(_names_file(v) for v in table.values()):
        return table
    sep = "" if label.endswith(".") else " "
    return {
        name: _read(values, n, folder, f"{origin}: {label}{sep}{_key(name)}", per)
        if _names_file(values)
        else values
        for name, values in table.items()
    }


def read_term_files(
    entries: Any, arity: int, folder: Path | None, origin: str, label: str, select_key: str
) -> Any:
    """A list of term tables (`label` "[[potential.pair]]", ...; `arity` 1 for bodies, 2 for
    pairs) with its entries' member lists (`select_key`) and data entries that name a file
    read; anything else is returned as it is, for the usual checks.

    Example:
        >>> import tempfile
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "bonds.csv").write_text("1, 2\\n2, 3\\n")
        >>> terms = [{"V": "dot(qi, qj)", "pairs": {"file": "bonds.csv"}}]
        >>> read_term_files(terms, 2, folder, "s.toml", "[[potential.pair]]", "pairs")[0]["pairs"]
        array([[1, 2],
               [2, 3]])
    """
    if isinstance(entries, (Mapping, str, bytes)) or not isinstance(entries, Sequence):
        return entries
    out = []
    for k, entry in enumerate(entries):
        if isinstance(entry, Mapping):
            where = f"{origin}: {label} #{k + 1}"
            entry = dict(entry)
            if _names_file(entry.get(select_key)):
                entry[select_key] = _members(entry[select_key], arity, folder, where, select_key)
            if isinstance(entry.get("data"), Mapping):
                named = f"{label} #{k + 1} data."
                entry["data"] = read_data_files(
                    entry["data"], None, folder, origin, named, "member"
                )
        out.append(entry)
    return out


def _names_file(values: Any) -> bool:
    return isinstance(values, Mapping) and "file" in values


def _read(
    entry: Mapping[str, Any], n: Any, folder: Path | None, where: str, per: str
) -> np.ndarray:
    """The array of one ``{ file = "..." }`` entry of data, checked."""
    path, suffix, at = _path(entry, folder, where)
    return _checked(_load(path, suffix, at), n, suffix, at, per)


def _members(
    entry: Mapping[str, Any], arity: int, folder: Path | None, where: str, key: str
) -> np.ndarray:
    """A member list from a file: whole numbers, one body (arity 1) or pair (2) per row (the
    body indices' range is checked with the term)."""
    path, suffix, at = _path(entry, folder, f"{where} {key}")
    array = _load(path, suffix, at)
    if array.dtype.kind not in "iuf":
        raise SpecError(f"{at}: expected body indices, got an array of {array.dtype}")
    if arity == 1 and array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]  # one body per line
    shape = "(rows,)" if arity == 1 else "(rows, 2)"
    if array.ndim != (1 if arity == 1 else 2) or (arity == 2 and array.shape[1] != 2):
        per_row = ("one body" if arity == 1 else "a pair i, j") + " per line"
        expected = per_row if suffix != ".npy" else f"shape {shape}"
        raise SpecError(f"{at}: expected {expected}, got shape {array.shape}")
    if len(array) == 0:
        raise SpecError(f"{at}: the file lists no {'bodies' if arity == 1 else 'pairs'}")
    whole = np.isfinite(array) & (array == np.round(array))
    if not whole.all():
        bad = np.flatnonzero(~whole.reshape(len(array), -1).all(axis=1))[0]
        raise SpecError(
            f"{at}: row {bad + 1} is not whole body indices ({shown(array[bad].tolist())})"
        )
    return array.astype(np.int64)


def _path(entry: Mapping[str, Any], folder: Path | None, where: str) -> tuple[Path, str, str]:
    """The file an entry names, its suffix and the message prefix naming it."""
    for key in entry:
        if key != "file":
            raise SpecError(f"{where}: unknown key {shown(key)} (allowed: file)")
    name = entry["file"]
    if not isinstance(name, str) or not name:
        raise SpecError(f"{where}: file: expected a file name (a string), got {shown(name)}")
    path = Path(name)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise SpecError(
            f"{where}: file {shown(name)}: unknown kind {shown(path.suffix)} (give a .npy, "
            ".txt or .csv file)"
        )
    if not path.is_absolute():
        if folder is None:
            raise SpecError(
                f"{where}: file {shown(name)} is relative, and the spec text has no folder "
                "(load the spec from its file, pass folder= to load_spec_text, or give an "
                "absolute path)"
            )
        path = folder / path
    return path, suffix, f"{where}: file {shown(str(path), 120)}"


def _load(path: Path, suffix: str, at: str) -> np.ndarray:
    """The file's array (no pickled objects); a missing or unreadable file is a SpecError."""
    if not path.exists():
        raise SpecError(f"{at}: no such file")
    try:
        if suffix == ".npy":
            loaded = np.load(path, allow_pickle=False)
        else:
            loaded = np.loadtxt(path, delimiter=SUFFIXES[suffix], ndmin=2, dtype=float)
    except ValueError as exc:
        why = " ".join(str(exc).split())
        if "pickle" in why:
            why = "it holds Python objects (only arrays of numbers are read)"
        raise SpecError(f"{at}: cannot read numbers from it ({shown(why, 100)})") from None
    except (OSError, EOFError) as exc:
        raise SpecError(f"{at}: cannot read the file ({' '.join(str(exc).split())})") from None
    if not isinstance(loaded, np.ndarray):  # e.g. an .npz archive under a .npy name
        raise SpecError(f"{at}: cannot read numbers from it (not a single .npy array)")
    return loaded


def _checked(array: np.ndarray, n: Any, suffix: str, at: str, per: str) -> np.ndarray:
    """`array` as floats of shape (n,) or (n, 3): numbers, finite, one row per `per`."""
    if array.dtype.kind not in "iuf":
        raise SpecError(f"{at}: expected numbers, got an array of {array.dtype}")
    if suffix != ".npy" and array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]  # one number per line
    if array.ndim not in (1, 2) or (array.ndim == 2 and array.shape[1] != 3):
        per_row = "one number or 3 numbers per line" if suffix != ".npy" else "shape (n,) or (n, 3)"
        raise SpecError(f"{at}: expected {per_row} (one per {per}), got shape {array.shape}")
    if isinstance(n, int) and not isinstance(n, bool) and len(array) != n:
        raise SpecError(f"{at}: expected {n} rows (one per {per}), got {len(array)}")
    out = array.astype(float)
    bad = np.flatnonzero(~np.isfinite(out.reshape(len(out), -1)).all(axis=1))
    if bad.size:
        raise SpecError(f"{at}: row {bad[0] + 1} is not finite ({shown(out[bad[0]].tolist())})")
    return out
