"""Print a Butcher tableau as the stage sums of the emitted C and NumPy.

Input: a `Tableau` (s2gen.tableaus). Output: a dict of term lists, one per stage sum: for
stage i, sum_j a_ij k_j; the solution's sum_j b_j k_j; the two error estimates. Only non-zero
coefficients appear, as round-trip literals, in the order of the stages (both languages add
in that order, so they round alike). C reads the component e of stage j as k[j][e], NumPy the
whole array k[j].

Example:
    >>> from s2gen.tableaus import DOP853
    >>> t = print_tableau(DOP853)
    >>> t["c_stages"][0], t["py_stages"][0]
    (('0.05260015195876773 * k[0][e]',), ('0.05260015195876773 * k[0]',))
    >>> t["c_stages"][1]
    ('0.0197250569845379 * k[0][e]', '+ 0.0591751709536137 * k[1][e]')
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from s2gen.tableaus import Tableau

__all__ = ["print_tableau"]


def _terms(coefficients: Sequence[float], stage: str) -> tuple[str, ...]:
    """`c_j * <stage j>` for the non-zero c_j, signs between the terms."""
    out: list[str] = []
    for j, c in enumerate(coefficients):
        if c == 0.0:
            continue
        text = f"{abs(c)!r} * {stage.format(j=j)}"
        if not out:
            out.append(text if c > 0 else f"-{text}")
        else:
            out.append(f"{'+' if c > 0 else '-'} {text}")
    return tuple(out)


def print_tableau(t: Tableau) -> dict[str, Any]:
    """The stage sums of `t` as C and NumPy term lists (see the module's docstring)."""
    rows = {"stages": t.a[1:], "b": (t.b,), "e5": (t.e5,), "e3": (t.e3,)}
    out: dict[str, Any] = {"stages": t.stages, "order": t.order}
    for lang, stage in (("c", "k[{j}][e]"), ("py", "k[{j}]")):
        for key, sums in rows.items():
            printed = tuple(_terms(row, stage) for row in sums)
            out[f"{lang}_{key}"] = printed if key == "stages" else printed[0]
    return out
