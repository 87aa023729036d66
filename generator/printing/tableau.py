"""Print a Butcher tableau as the stage sums of the emitted C and NumPy.

Input: a `Tableau` (s2gen.tableaus). Output: a dict of term lists, one per stage sum: for
stage i, sum_j a_ij k_j; the solution's sum_j b_j k_j; the two error estimates; the stages of
the continuous extension and its four coefficient sums (`dense_stages`, `dense_d`). Only non-zero
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
    rows = {
        "stages": t.a[1:],
        "b": (t.b,),
        "e5": (t.e5,),
        "e3": (t.e3,),
        "dense_stages": t.dense_a,
        "dense_d": t.dense_d,
    }
    several = ("stages", "dense_stages", "dense_d")
    out: dict[str, Any] = {
        "stages": t.stages,
        "order": t.order,
        "arrays": t.stages + 1 + len(t.dense_a),  # stage arrays: k[0] .. k[arrays - 1]
    }
    # the continuous extension's stages are k[stages + 1], ...; its sums are named d4 .. d7
    dense_k = range(t.stages + 1, t.stages + 1 + len(t.dense_a))
    dense_names = [f"d{r}" for r in range(4, 4 + len(t.dense_d))]
    for lang, stage in (("c", "k[{j}][e]"), ("py", "k[{j}]")):
        for key, sums in rows.items():
            printed = tuple(_terms(row, stage) for row in sums)
            out[f"{lang}_{key}"] = printed if key in several else printed[0]
        out[f"{lang}_dense_stages"] = tuple(zip(dense_k, out[f"{lang}_dense_stages"]))
        out[f"{lang}_dense_d"] = tuple(zip(dense_names, out[f"{lang}_dense_d"]))
    return out
