"""What a system's code needs: its inertia solver, coupling pairs and system-specific kernels.

Input: a `System`. Output: the solver chosen for its inertia (`choose_solver`, from the
structure `System.structure` found in M and the size n), the coupling pairs of M (which
off-diagonal entries are not identically zero) and the `KernelDef`s that depend on the system
itself: the potential V, its gradient dV/dq_i (taken by SymPy), and the entries or generators
of M, as functions of the parameters. Everything generic (the flow itself) comes from
`continuous.py`, `discrete.py` and `operators.py`.

Example:
    >>> import sympy as sp
    >>> from s2gen.system import System
    >>> from s2gen.symbols import q_symbol
    >>> m = sp.Symbol("m", real=True)
    >>> s = System.create(name="two", n=2, parameters={"m": 1.0},
    ...                   inertia=sp.diag(m, m), potential=q_symbol(1, 0) * q_symbol(2, 0))
    >>> coupling_pairs(s), choose_solver(s)
    ((), <InertiaKind.DIAGONAL: 'diagonal'>)
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.driven import tu_argument
from s2gen.inertia import INDEX, ChainInertia, Generators, InertiaKind, coupled_pairs
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import local_vector, q_symbols
from s2gen.system import SpecError, System, Term
from s2gen.terms import body_names

__all__ = [
    "choose_solver",
    "coupling_pairs",
    "has_general_potential",
    "per_body_inertia",
    "solve_cost",
    "system_kernels",
    "term_kernels",
]


def coupling_pairs(system: System) -> tuple[tuple[int, int], ...]:
    """0-based pairs (i, j), i < j, whose M_ij is not identically zero, in row order."""
    structure = system.structure
    if structure.pairs or not structure.coupled:
        return structure.pairs
    subs = dict(zip(system.parameter_symbols, system.parameter_values))
    return coupled_pairs(system.inertia, subs)  # a per-body M asked for the dense solvers


def solve_cost(kind: InertiaKind, n: int, bandwidth: int = 0) -> float:
    """Estimated operations of one coupled solve of the VI's Newton iteration (3n unknowns)
    by the solver for `kind`: dense LU (2/3 (3n)^3, plus the n^2/2 pair kernels of ~100
    operations), or the band elimination of `s2gen.equations.assemble` (rows x kl x
    (kl + ku) multiply-adds, plus ~300 operations per body to build the blocks).

    The emitted C solves a max-index M body by body (about 300 multiply-adds per body, the
    band as its fallback), but the estimate keeps the band's count: it also stands for the
    dense LU's fixed-width row updates, which vectorise. Measured
    (``benchmarks/structured_crossover.py``, rope and rod), the structured VI step is the
    faster from n = 6-7 at -O2 and n = 7-9 at -O3 -march=native; one emitted code serves
    both, and the estimate switches at n = 7.

    Example:
        >>> solve_cost(InertiaKind.MAX_INDEX, 100) < solve_cost(InertiaKind.DENSE, 100)
        True
    """
    if kind is InertiaKind.DENSE:
        return 2.0 / 3.0 * (3 * n) ** 3 + 50.0 * n * n
    if kind is InertiaKind.MAX_INDEX:
        rows, kl = 6 * n, 6
    else:
        rows, kl = 3 * n, 3 * bandwidth + 2
    return 2.0 * rows * kl * 2 * kl + 300.0 * n


def choose_solver(system: System) -> InertiaKind:
    """The solver of a system's coupled solves: DIAGONAL (none), DENSE, BANDED or MAX_INDEX.

    "auto" takes the structured solver of M's structure when it is estimated cheaper than
    the dense one (`solve_cost`); "dense" and "structured" force the choice (SpecError when M
    has no structure the structured solvers use).

    Example:
        >>> from s2gen.systems import builtin
        >>> choose_solver(builtin("double_pendulum"))
        <InertiaKind.DENSE: 'dense'>
    """
    structure = system.structure
    kind = structure.kind
    if kind is InertiaKind.DIAGONAL:
        return kind
    if system.inertia_solver == "dense":
        return InertiaKind.DENSE
    if system.inertia_solver == "structured":
        if kind is InertiaKind.DENSE:
            raise SpecError(
                f"{system.origin}: [inertia] solver = 'structured', but M is neither banded "
                "nor diagonal plus max-index (see s2gen.inertia); use 'auto' or 'dense'"
            )
        return kind
    if kind is InertiaKind.DENSE:
        return kind
    structured = solve_cost(kind, system.n, structure.bandwidth)
    return kind if structured < solve_cost(InertiaKind.DENSE, system.n) else InertiaKind.DENSE


def has_general_potential(system: System) -> bool:
    """True when V has an unstructured part (anything outside the terms)."""
    return system.potential != 0 or not system.terms


def per_body_inertia(system: System, solver: InertiaKind) -> ChainInertia | None:
    """The per-body inertia of a system whose code evaluates M body by body (a `ChainInertia`
    with the diagonal or the max-index solvers), else None (M's entries as one kernel).

    Example:
        >>> from s2gen.systems import builtin
        >>> rod = builtin("elastic_rod", n=20)
        >>> per_body_inertia(rod, choose_solver(rod)) is rod.chain
        True
    """
    if system.chain is None or solver not in (InertiaKind.DIAGONAL, InertiaKind.MAX_INDEX):
        return None
    return system.chain


def _inertia_kernel(system: System, solver: InertiaKind) -> KernelDef:
    """The kernel of M's entries: the diagonal and the coupled entries (pair order), or the
    generators of a max-index M (per body, from the spec's expressions and data, or as found)."""
    p = Argument("p", system.parameter_symbols)
    structure = system.structure
    doc = "diagonal of M and its coupled off-diagonal entries (pair order of the header)"
    chain = per_body_inertia(system, solver)
    if chain is not None:
        inputs = [p, Argument("i", (INDEX,), scalar=True)]
        inputs += [
            Argument(f"d_{d.name}", (s,), scalar=True)
            for d, s in zip(chain.data, chain.data_symbols())
        ]
        outputs = [("md", chain.diagonal)]
        if solver is InertiaKind.MAX_INDEX:
            outputs += [("sa", chain.scale), ("sc", chain.max_index)]
        return KernelDef(
            "inertia_body",
            "M per body: M_ii"
            + (
                ", the scale a_i and the max-index generator c_i (M_ij = a_i a_j c_max(i,j))"
                if solver is InertiaKind.MAX_INDEX
                else ""
            )
            + "; i is the 1-based body index",
            tuple(inputs),
            tuple(Output(name, (sp.sympify(e),), scalar=True) for name, e in outputs),
        )
    if solver is InertiaKind.MAX_INDEX:
        assert isinstance(structure.generators, Generators)
        gens = structure.generators
        uniform = all(d == gens.diagonal[0] for d in gens.diagonal)
        return KernelDef(
            "inertia",
            "diagonal of M, then the max-index generators a (scale) and c: "
            "M_ij = a_i a_j c_max(i,j) off the diagonal",
            (p,),
            (
                Output("mdiag", (gens.diagonal[0],) if uniform else gens.diagonal),
                Output("sa", gens.scale),
                Output("sc", gens.max_index),
            ),
            system=True,
        )
    pairs = coupling_pairs(system) if solver is not InertiaKind.DIAGONAL else ()
    M = system.inertia
    diag = [M[i, i] for i in range(system.n)]
    # a uniform diagonal is one value, filled in by a loop (code size independent of n)
    uniform = all(d == diag[0] for d in diag)
    outputs = [Output("mdiag", (diag[0],) if uniform else tuple(diag))]
    if pairs:
        outputs.append(Output("mpair", tuple(M[i, j] for i, j in pairs)))
    return KernelDef("inertia", doc, (p,), tuple(outputs), system=True)


def system_kernels(system: System, solver: InertiaKind | None = None) -> list[KernelDef]:
    """Inertia kernel and, when V has a general part, its potential and gradient."""
    p = Argument("p", system.parameter_symbols)
    kernels = [_inertia_kernel(system, choose_solver(system) if solver is None else solver)]
    if has_general_potential(system):
        q = Argument("q", tuple(q_symbols(system.n)))
        V = system.potential
        grad = tuple(sp.diff(V, s) for s in q.symbols)
        kernels += [
            KernelDef(
                "potential",
                "potential energy V(q) (general part)",
                (p, q, *tu_argument(system, V)),
                (Output("v", (V,), scalar=True),),
                system=True,
                stages=(("p", 0),),
            ),
            KernelDef(
                "gradient",
                "dV/dq, body-major (3 per body)",
                (p, q, *tu_argument(system, *grad)),
                (Output("g", grad),),
                system=True,
                stages=(("p", 0),),
            ),
        ]
    return kernels


def _translation_invariant(
    expr: sp.Expr, qi: tuple[sp.Symbol, ...], qj: tuple[sp.Symbol, ...]
) -> bool:
    """True when `expr` is seen to depend on qi and qj only through qi - qj: shifting both by
    the same t leaves it unchanged once SymPy's sums cancel the shift (a form that hides the
    difference, such as qi.qi - 2 qi.qj + qj.qj, is not seen: then False).

    Example:
        >>> a, b = sp.symbols("a_0:3"), sp.symbols("b_0:3")
        >>> r2 = sum((x - y) ** 2 for x, y in zip(a, b))
        >>> _translation_invariant(1 / r2, a, b), _translation_invariant(a[0] * b[0], a, b)
        (True, False)
    """
    t = sp.Dummy("t")
    for x, y in zip(qi, qj):
        if sp.sympify(expr).xreplace({x: x + t, y: y + t}) != expr:
            return False
    return True


def term_kernels(system: System, index: int, term: Term) -> tuple[KernelDef, KernelDef]:
    """Value and gradient kernels of one term, in its local positions, data and parameters."""
    p = Argument("p", system.parameter_symbols)
    positions = [Argument(role, local_vector(role)) for role in term.roles()]
    # data arguments are prefixed so that no datum name can clash with p, q, v, g, ...
    data = [Argument(f"d_{d.name}", d.symbols(), scalar=d.width == 1) for d in term.data]
    # per-body data vary with the member's bodies as positions do (stage 2: never hoisted
    # into member tables, which a cutoff term does not have), but are not coordinates
    body = [
        Argument(f"b_{body_names(d.name, term.kind)[r]}", s, scalar=d.width == 1)
        for d, r, s in term.body_symbols()
    ]
    inputs = (p, *positions, *data, *body, *tu_argument(system, term.expr))
    stages = (("p", 0), *((a.name, 1) for a in data), *((a.name, 2) for a in body))
    where = f"{term.label}: sum over {term.kind.plural}"
    grads = [
        Output(f"g{role[1:]}" if role != "q" else "g", tuple(sp.diff(term.expr, s) for s in pos))
        for role, pos in zip(term.roles(), (a.symbols for a in positions))
    ]
    if len(positions) == 2 and _translation_invariant(term.expr, *(a.symbols for a in positions)):
        # V(qi + t, qj + t) = V: the force on j is minus the force on i
        grads[1] = Output(grads[1].name, tuple(-e for e in grads[0].exprs))
    return (
        KernelDef(
            f"t{index}_value",
            f"{where} ({term.select}), value",
            inputs,
            (Output("v", (term.expr,), scalar=True),),
            stages=stages,
        ),
        KernelDef(
            f"t{index}_gradient",
            f"{where} ({term.select}), gradient",
            inputs,
            tuple(grads),
            stages=stages,
        ),
    )
