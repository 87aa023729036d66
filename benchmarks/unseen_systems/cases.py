"""The benchmark's cases: each system's spec, hand-written program, horizon and C data.

Input: a case name ("yukawa", "chain", "mixture"). Output: a `Case` (spec file, hand-written
program, steps and repeats per launch) and, for a loaded `System`, the C headers both programs
read: ``NAME_state.h`` (n, h and the initial state, as the spec's loader normalized it: the
emitted driver's only input besides the emitted code) and ``NAME_data.h`` (the state plus the
numbers the hand-written program needs: parameters, masses, charges, lengths, springs, sizes,
strengths). The numbers are read from the System, never retyped, and the structure the
hand-written program assumes (which data, which pairs, which inertia) is checked against the
spec first: a spec edited so that the hand-written program no longer models it is an error
here, not a silent mismatch.

Example:
    >>> case = CASES["chain"]
    >>> case.spec.name, case.hand.name, case.steps
    ('chain.toml', 'chain.c', 5000)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sp

from s2gen.symbols import q_symbol, vector
from s2gen.system import System, Term

__all__ = ["CASES", "HERE", "Case", "data_header", "state_header"]

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Case:
    """One benchmark system: its spec and hand-written program (files beside this module),
    the steps of one timed run (at the spec's h) and the runs per launch (median taken)."""

    name: str
    steps: int
    repeats: int
    what: str  # one line for the table's legend

    @property
    def spec(self) -> Path:
        return HERE / f"{self.name}.toml"

    @property
    def hand(self) -> Path:
        return HERE / f"{self.name}.c"


CASES: dict[str, Case] = {
    "yukawa": Case(
        "yukawa",
        2000,
        3,
        "100 charges, exp and sqrt over all 4950 pairs with per-body data; explicit VI",
    ),
    "chain": Case(
        "chain",
        5000,
        3,
        "10 coupled spherical pendula, dense M; implicit VI (Newton on 30 unknowns)",
    ),
    "mixture": Case(
        "mixture",
        250,
        3,
        "2000 Lennard-Jones particles of two species (per-body m, s, e), cutoff 0.2; explicit VI",
    ),
}


class CaseMismatch(ValueError):
    """The spec no longer has the structure its hand-written program assumes."""


def _array(name: str, values: Sequence[float] | np.ndarray) -> str:
    items = [repr(float(v)) for v in np.asarray(values, dtype=float).ravel()]
    rows = [", ".join(items[k : k + 4]) for k in range(0, len(items), 4)]
    body = ",\n    ".join(rows)
    return f"static const double {name}[{len(items)}] = {{\n    {body}\n}};\n"


def _define(name: str, value: float) -> str:
    text = repr(value) if isinstance(value, int) else repr(float(value))
    return f"#define {name} {text}\n"


def state_header(system: System) -> str:
    """``NAME_state.h``: BENCH_N, BENCH_H and the initial state BENCH_Q0, BENCH_W0 (body-major)."""
    if system.q0 is None or system.omega0 is None or system.run.h is None:
        raise CaseMismatch(f"{system.origin}: the benchmark needs [initial] q, omega and [run] h")
    return (
        f"/* {system.name}_state.h: n, h and the initial state of {system.name} "
        "(written by the benchmark from the spec) */\n"
        + _define("BENCH_N", system.n)
        + _define("BENCH_H", system.run.h)
        + _array("BENCH_Q0", system.q0)
        + _array("BENCH_W0", system.omega0)
    )


def _term(system: System, kind: str, select: str) -> Term:
    found = [t for t in system.terms if t.kind == kind and t.select == select]
    if len(found) != 1:
        raise CaseMismatch(
            f"{system.origin}: expected one {kind} term over {select!r}, found {len(found)}"
        )
    return found[0]


def _same(expr: sp.Expr, expected: sp.Expr, where: str) -> None:
    """The spec's expression is the formula the hand-written program implements."""
    if sp.simplify(expr - expected) != 0:
        raise CaseMismatch(f"{where}: expected {expected}, got {expr}")


def _same_values(expr: sp.Expr, expected: sp.Expr, where: str) -> None:
    """`_same` for expressions too large to simplify: equal as written, or equal in value at
    three points drawn in [0.5, 1.5] for every symbol (qi and qj kept apart)."""
    if expr == expected:
        return
    symbols = sorted(expr.free_symbols | expected.free_symbols, key=str)
    rng = np.random.default_rng(5)
    for _ in range(3):
        point = {s: float(v) for s, v in zip(symbols, rng.uniform(0.5, 1.5, len(symbols)))}
        a, b = float(expr.subs(point)), float(expected.subs(point))
        if not abs(a - b) <= 1e-9 * max(abs(a), abs(b), 1.0):
            raise CaseMismatch(f"{where}: expected {expected}, got {expr}")


def _symbols(*names: str) -> list[sp.Symbol]:
    return [sp.Symbol(name, real=True) for name in names]


def _datum(term: Term, name: str) -> np.ndarray:
    for d in term.data:
        if d.name == name and d.width == 1:
            return np.array(d.values)
    raise CaseMismatch(f"{term.label}: expected the scalar datum {name!r}")


def _body_datum(term: Term, name: str) -> np.ndarray:
    for d in term.body_data:
        if d.name == name and d.width == 1:
            return np.array(d.values)
    raise CaseMismatch(f"{term.label}: expected the per-body scalar {name!r} ([data])")


def _yukawa_data(system: System) -> str:
    """Masses (M's diagonal), charges (the per-body datum c of [data]) and A, kappa, E; the
    pair term must run over every pair (pairs = "all", no cutoff) and read c as ci and cj."""
    if not system.is_diagonal:
        raise CaseMismatch(f"{system.origin}: the yukawa program needs a diagonal inertia")
    field, pair = _term(system, "body", "all"), _term(system, "pair", "all")
    if pair.cutoff is not None:
        raise CaseMismatch(f"{pair.label}: the yukawa program visits every pair (no cutoff)")
    charge = _body_datum(field, "c")
    if not np.array_equal(_body_datum(pair, "c"), charge):
        raise CaseMismatch(f"{pair.label}: ci, cj must be the charges c of the field term")
    big_a, kappa, big_e, c, ci, cj = _symbols("A", "kappa", "E", "c", "ci", "cj")
    q, qi, qj = vector("q"), vector("qi"), vector("qj")
    r = sp.sqrt((qi - qj).dot(qi - qj))
    _same(system.potential, sp.Integer(0), f"{system.origin}: [potential] V")
    _same(field.expr, -big_e * c * q[2], field.label)
    _same(pair.expr, big_a * ci * cj * sp.exp(-kappa * r) / r, pair.label)
    params = system.parameters
    return (
        _define("YK_A", params["A"])
        + _define("YK_KAPPA", params["kappa"])
        + _define("YK_E", params["E"])
        + _array("YK_MASS", np.diag(system.inertia_numeric()))
        + _array("YK_CHARGE", charge)
    )


def _chain_data(system: System) -> str:
    """Masses m1..mn, lengths l1..ln, g and the springs (the chain term's data k); the spec's
    M must be l_i l_j (m_max(i,j) + ... + m_n)."""
    n, params = system.n, system.parameters
    mass = np.array([params[f"m{k}"] for k in range(1, n + 1)])
    length = np.array([params[f"l{k}"] for k in range(1, n + 1)])
    carried = np.cumsum(mass[::-1])[::-1]
    index = np.arange(n)
    expected = np.outer(length, length) * carried[np.maximum.outer(index, index)]
    if not np.allclose(system.inertia_numeric(), expected, rtol=1e-14, atol=0.0):
        raise CaseMismatch(f"{system.origin}: M is not l_i l_j (m_max(i,j) + ... + m_n)")
    m, ell = (
        _symbols(*[f"m{k}" for k in range(1, n + 1)]),
        _symbols(*[f"l{k}" for k in range(1, n + 1)]),
    )
    (g,) = _symbols("g")
    gravity = -g * sum(sum(m[i:]) * ell[i] * q_symbol(i + 1, 2) for i in range(n))
    _same(system.potential, gravity, f"{system.origin}: [potential] V")
    springs = _term(system, "pair", "chain")
    (k,) = _symbols("k")
    qi, qj = vector("qi"), vector("qj")
    _same(springs.expr, k * (1 - qi.dot(qj)), springs.label)
    return (
        _define("CH_G", params["g"])
        + _array("CH_MASS", mass)
        + _array("CH_LEN", length)
        + _array("CH_SPRING", _datum(springs, "k"))
    )


def _mixture_data(system: System) -> str:
    """rc, the cells per axis (floor(2 / rc)), masses (M's diagonal), sizes s and strengths e
    (per-body data); the pair term must run over the pairs closer than rc and read s and e as
    si, sj, ei, ej in the shifted Lennard-Jones potential with the Lorentz-Berthelot mixing
    rule."""
    if not system.is_diagonal:
        raise CaseMismatch(f"{system.origin}: the mixture program needs a diagonal inertia")
    if len(system.terms) != 1:
        raise CaseMismatch(f"{system.origin}: expected the pair term alone")
    pair, params = _term(system, "pair", "all"), system.parameters
    if pair.cutoff is None or pair.cutoff != params["rc"]:
        raise CaseMismatch(f"{pair.label}: the mixture program needs cutoff = rc")
    if not 0.0 < params["rc"] <= 1.0:
        raise CaseMismatch(f"{pair.label}: the mixture program needs 0 < rc <= 1")
    rc, si, sj, ei, ej = _symbols("rc", "si", "sj", "ei", "ej")
    qi, qj = vector("qi"), vector("qj")
    x = (si + sj) ** 2 / (4 * (qi - qj).dot(qi - qj))
    xc = (si + sj) ** 2 / (4 * rc**2)
    _same(system.potential, sp.Integer(0), f"{system.origin}: [potential] V")
    _same_values(pair.expr, 4 * sp.sqrt(ei * ej) * (x**6 - x**3 - xc**6 + xc**3), pair.label)
    return (
        _define("MX_RC", params["rc"])
        + _define("MX_NC", int(2.0 / params["rc"]))
        + _array("MX_MASS", np.diag(system.inertia_numeric()))
        + _array("MX_SIGMA", _body_datum(pair, "s"))
        + _array("MX_EPS", _body_datum(pair, "e"))
    )


_DATA: dict[str, Callable[[System], str]] = {
    "yukawa": _yukawa_data,
    "chain": _chain_data,
    "mixture": _mixture_data,
}


def data_header(case: Case, system: System) -> str:
    """``NAME_data.h``: the state header and the numbers the hand-written program needs."""
    return (
        f"/* {system.name}_data.h: the data of {case.spec.name} for the hand-written program "
        "(written by the benchmark from the spec) */\n"
        f'#include "{system.name}_state.h"\n' + _DATA[case.name](system)
    )
