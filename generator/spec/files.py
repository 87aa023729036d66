"""Per-body data read from files: a [data] or [inertia.data] entry that names a file.

Input: the spec's [data] and [inertia] tables as TOML read them, the body count, the folder
of the spec file (None for spec text with no file) and the spec's origin. Output: the same
tables with each ``name = { file = "..." }`` entry replaced by the file's values as a float
array of shape (n,) (one number per body) or (n, 3) (one 3-vector per body), or a one-line
`SpecError` naming the key and the file. Files are ``.npy`` (read with
``numpy.load(allow_pickle=False)``), ``.txt`` (numbers separated by spaces) or ``.csv``
(separated by commas), one row per body; a relative path is relative to the spec's folder::

    [data]
    charge = { file = "charges.npy" }     # shape (n,)
    offset = { file = "offsets.csv" }     # n rows of 3 numbers

The values then go through the same checks as values written inline, so a spec reads the
same numbers (and has the same `System.spec_digest`) either way; the digest hashes the values,
so it changes when a file's content changes.

Example:
    >>> read_data_files({"c": [1.0, 2.0]}, 2, None, "s", "[data]")
    {'c': [1.0, 2.0]}
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from s2gen.errors import SpecError, shown
from s2gen.spec.tables import _key

__all__ = ["read_data_files"]

#: The file suffixes a datum may name, and the column separator of the text ones.
SUFFIXES = {".npy": None, ".txt": None, ".csv": ","}


def read_data_files(table: Any, n: Any, folder: Path | None, origin: str, label: str) -> Any:
    """`table` (a [data]-like table, name = values) with the entries that name a file read
    into arrays; anything else is returned as it is, for the usual checks. `label` names the
    table in messages ("[data]" or "[inertia] data."); `n` is the body count when valid.

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
        name: _read(values, n, folder, f"{origin}: {label}{sep}{_key(name)}")
        if _names_file(values)
        else values
        for name, values in table.items()
    }


def _names_file(values: Any) -> bool:
    return isinstance(values, Mapping) and "file" in values


def _read(entry: Mapping[str, Any], n: Any, folder: Path | None, where: str) -> np.ndarray:
    """The array of one ``{ file = "..." }`` entry, checked."""
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
    at = f"{where}: file {shown(str(path), 120)}"
    array = _load(path, suffix, at)
    return _checked(array, n, suffix, at)


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


def _checked(array: np.ndarray, n: Any, suffix: str, at: str) -> np.ndarray:
    """`array` as floats of shape (n,) or (n, 3): numbers, finite, one row per body."""
    if array.dtype.kind not in "iuf":
        raise SpecError(f"{at}: expected numbers, got an array of {array.dtype}")
    if suffix != ".npy" and array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]  # one number per line
    if array.ndim not in (1, 2) or (array.ndim == 2 and array.shape[1] != 3):
        per_row = "one number or 3 numbers per line" if suffix != ".npy" else "shape (n,) or (n, 3)"
        raise SpecError(f"{at}: expected {per_row} (one per body), got shape {array.shape}")
    if isinstance(n, int) and not isinstance(n, bool) and len(array) != n:
        raise SpecError(f"{at}: expected {n} rows (one per body), got {len(array)}")
    out = array.astype(float)
    bad = np.flatnonzero(~np.isfinite(out.reshape(len(out), -1)).all(axis=1))
    if bad.size:
        raise SpecError(f"{at}: row {bad[0] + 1} is not finite ({shown(out[bad[0]].tolist())})")
    return out
