"""The monitor of the time-transformed methods: how fast a closed system with pair terms moves.

Input: a `System` (its pair terms and parameters). Output: `Monitor`, one `PairRate` per pair
term: the term's profile f(c) (its value as a function of c = qi.qj), the rate r(c) and its
derivative r'(c) as SymPy expressions in c and the parameters, with the term's members. The
monitor is R(q) = sum over the pair terms and their members (i, j) of r(qi.qj); the
time-transformed methods (`vi-adaptive`, ...) take steps dt = eps / xi with xi tracking R
reversibly, so R is the inverse of the local time scale.

The rule. A pair potential that depends on qi and qj only through c = qi.qj = cos(theta) is
f(c); in the pair's angle theta its derivatives are V' = -f'(c) sin(theta) and
V'' = f''(c) (1 - c^2) - c f'(c). A pair with unit inertia oscillates about a stable angle with
frequency sqrt(|V''|); near a singularity of f (wherever it is: theta -> 0 as for gravity, or
theta -> pi as for the cotangent potential of the three bodies) |V''| grows like the inverse
cube of the distance, and sqrt(|V''|) is then the Kepler rate r^(-3/2) of a close encounter.
V'' alone vanishes at inflection points (a softened potential), and |V'|/sin(theta) = |f'(c)|
is the second, never-vanishing part of the same Hessian (the curvature term of the sphere).
So

    r(c) = (f'(c)^2 + (f''(c) (1 - c^2) - c f'(c))^2)^(1/4),

the square root of the norm of the pair's Hessian in (theta, its tangent direction), which is
smooth wherever f is, positive wherever f' or V'' is nonzero, and grows like the encounter
rate at every singular point of f in [-1, 1]. The monitor is derived here, once, in the
generic pair's symbols; a term that is not a function of qi.qj alone (checked at random unit
pairs), that reads per-member or per-body data, or whose profile is constant is refused in
one line, and so is a system with other potentials; a spec may instead give its own monitor
as [run] g, an expression in q1..qn and the parameters (then any closed system is taken).

Example:
    >>> from s2gen.systems import builtin
    >>> mon = monitor(builtin("three_bodies"))
    >>> [r.label for r in mon.rates], mon.rates[0].members
    (['cotangent attraction'], ((0, 1), (0, 2), (1, 2)))
    >>> mon.rates[0].profile
    -c*gamma/sqrt(1 - c**2)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from s2gen.ir import Argument, KernelDef, Output
from s2gen.spec.parser import parse_expression
from s2gen.symbols import local_vector, q_symbols, w_symbol
from s2gen.system import System
from s2gen.terms import Term, TermKind

__all__ = [
    "MONITOR_MAX_PAIRS",
    "C",
    "Monitor",
    "PairRate",
    "emitted_refusal",
    "monitor",
    "monitor_kernel",
]

#: The emitted monitor is one expression summed over its pairs: at most this many of them.
MONITOR_MAX_PAIRS = 64

#: The variable of a pair's profile: c = qi.qj.
C = sp.Symbol("c", real=True)


@dataclass(frozen=True)
class PairRate:
    """One pair term's share of the monitor: r(c) summed over `members` (0-based pairs)."""

    label: str
    profile: sp.Expr
    rate: sp.Expr
    slope: sp.Expr
    members: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class Monitor:
    """R(q) = sum over `rates` and their members (i, j) of rate(qi.qj), or the spec's own
    `given` R in the global symbols q1_0..qn_2, in the parameters `parameters` (the system's,
    in declared order)."""

    rates: tuple[PairRate, ...]
    parameters: tuple[sp.Symbol, ...]
    given: sp.Expr | None = None


def _profile(expr: sp.Expr, label: str) -> sp.Expr:
    """f(c): the pair expression at qi = e1, qj = (c, sqrt(1 - c^2), 0)."""
    qi, qj = local_vector("qi"), local_vector("qj")
    at = dict(zip(qi, (1, 0, 0))) | dict(zip(qj, (C, sp.sqrt(1 - C**2), 0)))
    return sp.simplify(sp.sympify(expr).subs(at))


def _check_invariant(
    expr: sp.Expr, profile: sp.Expr, params: dict[sp.Symbol, float], label: str
) -> None:
    """Refuse a term that is not f(qi.qj) at a few random unit pairs."""
    qi, qj = local_vector("qi"), local_vector("qj")
    rng = np.random.default_rng(2026)
    value = sp.lambdify([*qi, *qj], sp.sympify(expr).subs(params), "math")
    along = sp.lambdify([C], profile.subs(params), "math")
    for _ in range(4):
        a, b = rng.normal(size=(2, 3))
        a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
        v, f = complex(value(*a, *b)), complex(along(float(a @ b)))
        if not abs(v - f) <= 1e-9 * max(1.0, abs(v)):
            raise ValueError(
                f"pair term {label!r} is not a function of qi.qj alone: the time-transformed "
                "methods derive their monitor from such terms only"
            )


def _monitored_terms(system: System) -> list[Term]:
    """The pair terms the rule of the module docstring derives the monitor from; ValueError in
    one line when the system has other potentials or no pair term."""
    pairs = [t for t in system.terms if t.kind is TermKind.PAIR and t.count(system.n) > 0]
    if not pairs or system.potential != 0 or len(pairs) < len(system.terms):
        raise ValueError(
            f"{system.name}: the time-transformed methods take closed systems with pair terms "
            "and no other potential, or a monitor [run] g (this one has "
            f"{'other potential terms' if pairs else 'no pair term'})"
        )
    return pairs


def monitor(system: System) -> Monitor:
    """The monitor of a closed system: the spec's [run] g when it gives one (any closed
    system), else the pair rule of the module docstring; ValueError in one line for a driven
    system, or without g for one with other potentials than pair terms or a pair term the
    rule does not cover.

    Example:
        >>> from s2gen.systems import builtin
        >>> r = monitor(builtin("three_bodies")).rates[0]
        >>> g = sp.Symbol("gamma", real=True)
        >>> bool(sp.simplify(r.rate**4 - g**2 * (1 + 4 * C**2) / (1 - C**2) ** 3) == 0)
        True
    """
    why = "the time-transformed methods take closed systems with pair terms"
    system.refuse_driven("the time-transformed methods")
    names = tuple(sp.Symbol(p, real=True) for p in system.parameter_names)
    if system.run.g is not None:
        given = parse_expression(
            system.run.g, n=system.n, parameters=system.parameter_names, where="[run] g"
        )
        return Monitor((), names, given)
    pairs = _monitored_terms(system)
    params = {sp.Symbol(p, real=True): v for p, v in system.parameters.items()}
    rates = []
    for t in pairs:
        if t.data or t.body_data:
            raise ValueError(f"pair term {t.label!r}: {why} without per-member or per-body data")
        f = _profile(t.expr, t.label)
        _check_invariant(t.expr, f, params, t.label)
        d1 = sp.diff(f, C)
        if sp.simplify(d1) == 0:
            raise ValueError(f"pair term {t.label!r} is constant: it sets no time scale")
        d2 = sp.diff(f, C, 2)
        rate = (d1**2 + (d2 * (1 - C**2) - C * d1) ** 2) ** sp.Rational(1, 4)
        members = tuple((int(m[0]), int(m[1])) for m in t.member_list(system.n))
        rates.append(PairRate(t.label, f, rate, sp.diff(rate, C), members))
    return Monitor(tuple(rates), names)


def emitted_refusal(system: System) -> str | None:
    """Why the emitted C and NumPy of `system` have no time-transformed driver, in one line
    (None: they have one): no monitor (`monitor`), pair terms within a cutoff, or more than
    `MONITOR_MAX_PAIRS` monitored pairs (a monitor given as [run] g takes any closed system).

    Example:
        >>> from s2gen.systems import builtin
        >>> emitted_refusal(builtin("three_bodies")) is None
        True
    """
    # the refusals that need no derivation first: deriving a large system's monitor only to
    # refuse it would cost a cold generation a third of a second
    try:
        system.refuse_driven("the time-transformed methods")
        terms = [] if system.run.g is not None else _monitored_terms(system)
    except ValueError as e:
        return str(e)
    if any(t.cutoff is not None for t in terms):
        return (
            f"{system.name}: the emitted time-transformed methods do not take pair terms within "
            "a cutoff (their pairs are found per call): use the reference backend or give a "
            "monitor as [run] g"
        )
    pairs = sum(t.count(system.n) for t in terms)
    if pairs <= MONITOR_MAX_PAIRS:
        try:
            monitor(system)
        except ValueError as e:
            return str(e)
    if pairs > MONITOR_MAX_PAIRS:
        return (
            f"{system.name}: the emitted time-transformed methods take at most "
            f"{MONITOR_MAX_PAIRS} monitored pairs (this system has {pairs}): use the reference "
            "backend or give a monitor as [run] g"
        )
    return None


def monitor_kernel(system: System) -> KernelDef | None:
    """The emitted monitor: a system kernel of (p, q, w) with the scalar outputs r = R(q) and
    dr = dR/dt = grad R . qdot (qdot_i = w_i x q_i), from the same expressions as `monitor`
    (each pair term's rate at qi.qj, summed over its members, or the spec's g); None when the
    system has no monitor (`monitor` refuses it).

    Example:
        >>> from s2gen.systems import builtin
        >>> k = monitor_kernel(builtin("three_bodies"))
        >>> k.name, [o.name for o in k.outputs], monitor_kernel(builtin("double_pendulum"))
        ('monitor', ['r', 'dr'], None)
    """
    if emitted_refusal(system) is not None:
        return None
    mon = monitor(system)
    n = system.n
    qs = q_symbols(n)
    ws = tuple(w_symbol(i, a) for i in range(1, n + 1) for a in range(3))
    q = [sp.Matrix(qs[3 * i : 3 * i + 3]) for i in range(n)]
    qdot = [sp.Matrix(ws[3 * i : 3 * i + 3]).cross(q[i]) for i in range(n)]
    if mon.given is not None:
        R = mon.given
        dR = sum(sp.diff(R, qs[3 * i + a]) * qdot[i][a] for i in range(n) for a in range(3))
    else:
        R = dR = sp.Integer(0)
        for r in mon.rates:
            for i, j in r.members:
                c = q[i].dot(q[j])
                R += r.rate.subs(C, c)
                dR += r.slope.subs(C, c) * (qdot[i].dot(q[j]) + q[i].dot(qdot[j]))
    return KernelDef(
        "monitor",
        "monitor R(q) of the time-transformed methods and dR/dt",
        (Argument("p", system.parameter_symbols), Argument("q", tuple(qs)), Argument("w", ws)),
        (Output("r", (R,), scalar=True), Output("dr", (dR,), scalar=True)),
        system=True,
    )
