"""Print Butcher tableaus (s2gen.tableaus) into the emitted C and NumPy.

`print_explicit`: a fixed-step `Explicit` tableau as its stage increments and its update,
h times a combination of the stages with the common denominator of the coefficients taken
out (h / 6.0 * (k0 + 2.0 * k1 + ...)), so that binary fractions and small integers round as
written by hand. `print_pair`: the coefficient tables of an `EmbeddedPair` as exact fractions
(C 3.0 / 40, NumPy 3 / 40), which both languages round to the nearest double.

`print_tableau`: a `Tableau`. Output: a dict of term lists, one per stage sum: for
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

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from s2gen.methods import explicit_tableaus, fixed_methods
from s2gen.tableaus import EmbeddedPair, Explicit, Tableau

__all__ = [
    "PrintedExplicit",
    "PrintedFixed",
    "PrintedPair",
    "print_explicit",
    "print_fixed",
    "print_pair",
    "print_tableau",
]


@dataclass(frozen=True)
class PrintedExplicit:
    """A fixed-step tableau in both languages: `c_arrays` declares the C stage arrays k1, k2,
    ... after k0 (name, initializer); `c_stages[i - 1]` is (stage i's increment h sum_j a_ij k_j
    on component e, the name of stage i's array); `c_update` the step's h sum_j b_j k_j;
    `py_*` the increments on whole NumPy arrays k0, k1, ..."""

    name: str
    title: str
    order: int
    stages: int
    c_arrays: tuple[tuple[str, str], ...]
    c_stages: tuple[tuple[str, str], ...]
    c_update: str
    py_stages: tuple[str, ...]
    py_update: str


@dataclass(frozen=True)
class PrintedPair:
    """An embedded pair's tables: C initializer rows of a (zero-padded to `stages - 1`
    columns), e (four per row) and the continuous extension; NumPy tuples of a's rows, e and the
    continuous extension's rows."""

    stages: int
    c_a: tuple[str, ...]
    c_e: tuple[str, ...]
    c_dense: tuple[str, ...]
    py_a: tuple[str, ...]
    py_e: str
    py_dense: tuple[str, ...]


def _combination(coefficients: Sequence[Fraction], stage: Callable[[int], str]) -> str:
    """h times sum_j coefficients[j] * stage(j), the common denominator d taken out as h / d."""
    nonzero = [(j, x) for j, x in enumerate(coefficients) if x != 0]
    d = math.lcm(*(x.denominator for _, x in nonzero))
    terms: list[str] = []
    for j, x in nonzero:
        n = abs(x * d)
        text = stage(j) if n == 1 else f"{float(n)!r} * {stage(j)}"
        sign = ("-" if x < 0 else "") if not terms else ("- " if x < 0 else "+ ")
        terms.append(sign + text)
    scale = "h" if d == 1 else f"h / {float(d)!r}"
    single = len(terms) == 1 and terms[0] == stage(nonzero[0][0])
    return f"{scale} * {terms[0]}" if single else f"{scale} * ({' '.join(terms)})"


def print_explicit(t: Explicit, ns: str) -> PrintedExplicit:
    """`t` printed; `ns` is the C name of the state length (the stride of the stage arrays).

    Example:
        >>> from s2gen.tableaus import RK4
        >>> p = print_explicit(RK4, "X_NS")
        >>> p.c_arrays[1], p.c_stages[1], p.py_update[:16]
        (('k2', 'k0 + 2 * X_NS'), ('h / 2.0 * k1[e]', 'k2'), 'h / 6.0 * (k0 + ')
    """

    def c_stage(j: int) -> str:
        return f"k{j}[e]"

    def py_stage(j: int) -> str:
        return f"k{j}"

    return PrintedExplicit(
        t.name,
        t.title,
        t.order,
        t.stages,
        tuple((f"k{i}", "k0 + " + (ns if i == 1 else f"{i} * {ns}")) for i in range(1, t.stages)),
        tuple((_combination(row, c_stage), f"k{i}") for i, row in enumerate(t.a[1:], 1)),
        _combination(t.b, c_stage),
        tuple(_combination(row, py_stage) for row in t.a[1:]),
        _combination(t.b, py_stage),
    )


@dataclass(frozen=True)
class PrintedFixed:
    """One row of the emitted dispatch table of the fixed-step methods: the method's enum
    constant (suffix), its tableau's name and position among the module's tableaus
    (s2gen.methods.explicit_tableaus), evaluations per step, and whether each q_i is
    normalized after the step (1 or True) or not (0 or False), as C and NumPy write it."""

    c_name: str
    tableau: str
    index: int
    evals: int
    project: int
    py_project: str


def print_fixed(kind: str) -> tuple[PrintedFixed, ...]:
    """The dispatch rows of the fixed-step methods of the module kind `kind`.

    Example:
        >>> row = print_fixed("angles")[0]
        >>> row.c_name, row.tableau, row.evals, row.project, row.py_project
        ('METHOD_RK4', 'rk4', 4, 0, 'False')
    """
    index = {t.name: i for i, t in enumerate(explicit_tableaus(kind))}
    return tuple(
        PrintedFixed(
            m.c_name,
            m.tableau.name,
            index[m.tableau.name],
            m.evals,
            int(m.project),
            repr(m.project),
        )
        for m in fixed_methods(kind)
        if m.tableau is not None
    )


def _c_fraction(x: Fraction) -> str:
    if x == 0:
        return "0"
    return f"{x.numerator}.0" + ("" if x.denominator == 1 else f" / {x.denominator}")


def _py_fraction(x: Fraction) -> str:
    if x.denominator == 1:
        return f"{x.numerator}.0"
    return f"{x.numerator} / {x.denominator}"


def _py_tuple(items: Sequence[str]) -> str:
    return f"({items[0]},)" if len(items) == 1 else f"({', '.join(items)})"


def print_pair(t: EmbeddedPair) -> PrintedPair:
    """The tables of `t` as exact fractions (see the module's docstring).

    Example:
        >>> from s2gen.tableaus import DOPRI5
        >>> p = print_pair(DOPRI5)
        >>> p.c_a[2], p.py_a[1], p.c_e[1]
        ('3.0 / 40, 9.0 / 40, 0, 0, 0, 0', '(1 / 5,)', '-17253.0 / 339200, 22.0 / 525, -1.0 / 40')
    """
    width = t.stages - 1
    e = [_c_fraction(x) for x in t.e]
    return PrintedPair(
        t.stages,
        tuple(
            ", ".join(_c_fraction(x) for x in (*row, *[Fraction(0)] * (width - len(row))))
            for row in t.a
        ),
        tuple(", ".join(e[k : k + 4]) for k in range(0, len(e), 4)),
        tuple(", ".join(_c_fraction(x) for x in row) for row in t.dense),
        tuple(_py_tuple([_py_fraction(x) for x in row]) for row in t.a),
        ", ".join(_py_fraction(x) for x in t.e),
        tuple(", ".join(_py_fraction(x) for x in row) for row in t.dense),
    )


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
