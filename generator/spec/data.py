"""The spec's [data] table: per-body arrays, one number or one 3-vector per body.

Input: the table (TOML or `define_system`'s `data`, name = list of n entries), the body count,
the parameters and the spec's origin. Output: one `TermData` per name (`width` 1 or 3, n
entries body-major), or a `SpecError` naming the key and the offending entry. Entries that are
plain numbers are converted in one NumPy call (no SymPy per number: 10^6 values load in well
under a second); an entry that is an expression string in the parameters is evaluated on its
own. Term expressions read a datum c as `c` (body terms) or `ci` and `cj` (pair terms, any
selection), the per-body inertia as `c` (scalar data only)::

    [data]
    charge = [1.0, -1.0, 1.0]
    offset = [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]

Example:
    >>> [(d.name, d.width, d.values) for d in body_data({"c": [1, "2*k"]}, 2, {"k": 0.5}, "s")]
    [('c', 1, (1.0, 1.0))]
"""

from __future__ import annotations

import numbers
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from s2gen.errors import SpecError, shown
from s2gen.spec.tables import _check_data_name, _key, _number
from s2gen.terms import TermData

__all__ = ["body_data", "scalar_data"]

_KINDS = {1: "a number", 3: "a 3-vector"}


def body_data(data: Any, n: int, params: Mapping[str, float], origin: str) -> tuple[TermData, ...]:
    """The per-body arrays of a [data] table (None: none), checked name by name."""
    if data is None:
        return ()
    if not isinstance(data, Mapping):
        raise SpecError(
            f"{origin}: [data]: expected a table of name = list of values, got {shown(data)}"
        )
    return tuple(
        _datum(name, values, n, params, f"{origin}: [data] {_key(name)}")
        for name, values in data.items()
    )


def _datum(name: Any, values: Any, n: int, params: Mapping[str, float], where: str) -> TermData:
    _check_data_name(name, params, where)
    if name == "t":
        raise SpecError(f"{where}: the name 't' is time in term expressions (rename the datum)")
    if isinstance(values, Mapping) and "file" in values:
        raise SpecError(
            f"{where}: a {{file = ...}} entry is read in TOML specs; in Python pass the array "
            "(e.g. numpy.load(path))"
        )
    if isinstance(values, (str, bytes, Mapping)) or not hasattr(values, "__len__"):
        raise SpecError(
            f"{where}: expected a list of {n} values (one per body), got {shown(values)}"
        )
    if len(values) != n:
        raise SpecError(f"{where}: expected {n} values (one per body), got {len(values)}")
    fast = _plain(values)
    if fast is not None:
        width = 1 if fast.ndim == 1 else 3
        return TermData(name, width, tuple(fast.ravel().tolist()))
    widths = [_width(entry, f"{where}[{b + 1}]") for b, entry in enumerate(values)]
    for b, width in enumerate(widths):
        if width != widths[0]:
            raise SpecError(
                f"{where}[{b + 1}]: {_KINDS[width]}, but entry 1 is {_KINDS[widths[0]]} "
                "(a datum is all numbers or all 3-vectors)"
            )
    flat = [
        _number(v, f"{where}[{b + 1}]" + (f"[{c + 1}]" if widths[0] == 3 else ""), params)
        for b, entry in enumerate(values)
        for c, v in enumerate(list(entry) if widths[0] == 3 else [entry])
    ]
    return TermData(name, widths[0], tuple(flat))


def _plain(values: Any) -> np.ndarray | None:
    """The values as a finite float array of shape (n,) or (n, 3) when they are plain numbers
    (not strings or booleans), else None (then they are read entry by entry)."""
    try:
        array = np.asarray(values)
    except ValueError:  # ragged
        return None
    if array.dtype.kind not in "iuf" or array.ndim not in (1, 2):
        return None
    if array.ndim == 2 and array.shape[1] != 3:
        return None
    out = array.astype(float)
    return out if bool(np.all(np.isfinite(out))) else None


def _width(entry: Any, where: str) -> int:
    """1 for a number or an expression string, 3 for a 3-vector; anything else is an error."""
    if isinstance(entry, str) or (isinstance(entry, numbers.Real) and not isinstance(entry, bool)):
        return 1
    if isinstance(entry, (list, tuple, np.ndarray)) and len(entry) == 3:
        return 3
    got = f"a list of {len(entry)}" if isinstance(entry, (list, tuple)) else shown(entry)
    raise SpecError(f"{where}: expected a number or a 3-vector, got {got}")


def scalar_data(
    data: tuple[TermData, ...], texts: tuple[Any, ...], where: str
) -> tuple[TermData, ...]:
    """The scalar data the per-body inertia expressions `texts` name (a 3-vector datum named
    there is an error: the inertia needs one number per body).

    Example:
        >>> c, r = TermData("c", 1, (1.0,)), TermData("r", 3, (0.0, 0.0, 1.0))
        >>> [d.name for d in scalar_data((c, r), ("c*m", None), "s: [inertia]")]
        ['c']
    """
    words = {w for text in texts if isinstance(text, str) for w in re.findall(r"\w+", text)}
    for d in data:
        if d.width == 3 and d.name in words:
            raise SpecError(
                f"{where}: the datum {shown(d.name)} of [data] is a 3-vector per body, and the "
                "inertia needs one number per body"
            )
    return tuple(d for d in data if d.width == 1)
