"""Pass `layout`: pair loops laid out as rows or sorted cells the compiler can vectorise.

Input: a `Module`. Output: the same module with

- every term over all pairs (no cutoff, not in the quadratic matrix) marked `rows`: its
  emitted loop runs over rows i with a contiguous inner loop over the partners j > i, on
  structure-of-arrays copies of q (and of g for the gradient) kept in the workspace, with the
  term's kernel written inline and the row's sums as OpenMP SIMD reductions; per-body data are
  read from their tables by body index (body i once per row, the partners j in order:
  contiguous for numbers, every third double for a 3-vector's component); when the gradient
  kernel calls a libm function (exp, log, ...), which gcc does not vectorise, its row loop is
  split at the calls (`s2gen.passes.fission`) so that the rest vectorises;
- every term over the pairs within a cutoff whose value is symmetric in its two bodies (the
  same number with qi and qj, and each per-body datum's i and j, swapped) and that reads only
  q, numbers per body and the shared constants, marked `sorted_cells`: its gradient sorts the
  bodies by cell into structure-of-arrays copies of q and of the per-body numbers, meets each
  pair once (a cell with itself and a half stencil of 13 cells) and runs each partner cell's
  contiguous range as a SIMD loop with the kernel inline and the cutoff as a mask. Symmetry is
  what lets a pair be evaluated in the order the cells meet it rather than as (i < j); it is
  tested by evaluating the value kernel at random points with the bodies swapped.

Each pair is still evaluated once, and every operation stays an IEEE operation (only the order
of the sums changes). Functions that run without a workspace keep the member loop.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> [t.rows for t in lower_system(builtin("molecular")).terms]
    [True]
    >>> [t.sorted_cells for t in lower_system(builtin("lj_cutoff")).terms]
    [True]
"""

from __future__ import annotations

import math
import random
from dataclasses import replace

import sympy as sp

from s2gen.ir import Fission, Kernel, LoopKind, Module, TermLoop
from s2gen.passes.fission import split_at_calls
from s2gen.terms import body_names

__all__ = ["STACK_BYTES", "contiguous", "layout_pass", "symmetric_pair"]


def contiguous(t: TermLoop) -> bool:
    """Whether the term's member loop can run as rows (all pairs, no per-member data), unless
    its members go into the quadratic matrix instead.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.equations.assemble import sphere_module
        >>> [contiguous(t) for t in sphere_module(builtin("dipoles")).terms]  # a listed term
        [False]
    """
    return t.loop.kind is LoopKind.ALL_PAIRS and not t.data


#: Random points at which a pair kernel is evaluated with its bodies swapped.
_POINTS = 3
#: Largest relative difference of the two values taken as equal: they are evaluated with 30
#: significant digits, so a symmetric term differs only by that round-off, and a term with a
#: small asymmetric part (say 1e-12 of its size) is still told apart.
_TOLERANCE = 1e-20


def _unit(rng: random.Random) -> list[float]:
    v = [rng.gauss(0.0, 1.0) for _ in range(3)]
    norm = math.sqrt(sum(x * x for x in v))
    return [x / norm for x in v]


def _evaluate(kernel: Kernel, values: dict[sp.Symbol, float]) -> float | None:
    """The kernel's scalar output at `values` (one number per input symbol, matched by name),
    or None if it is not a finite real number."""
    env: dict[str, sp.Expr] = {s.name: sp.Float(v, 30) for s, v in values.items()}
    out = None
    try:
        for a in kernel.assignments:
            known = {s: env[s.name] for s in a.expr.free_symbols if s.name in env}
            value = sp.N(a.expr.xreplace(known).doit(), 30)
            if a.temp is not None:
                env[a.temp.name] = value
            else:
                out = complex(value)
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    if out is None or out.imag != 0.0 or not math.isfinite(out.real):
        return None
    return out.real


def symmetric_pair(kernel: Kernel, data: tuple[tuple[str, int, int], ...]) -> bool:
    """Whether a pair term's value kernel (inputs qi, qj, per-body numbers b_<d>i, b_<d>j as
    `data` names them, shared constants) gives the same value with the bodies swapped, at
    `_POINTS` random points (unit vectors, numbers in [0.5, 1.5]); False for any other input.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("lj_cutoff"))
        >>> symmetric_pair(m.kernel(m.terms[0].value), m.terms[0].body_data)
        True
    """
    kind = LoopKind.CUTOFF_PAIRS.kind
    pairs = {f"b_{body_names(name, kind)[r]}": (name, r) for name, width, r in data if width == 1}
    if any(width != 1 for _, width, _ in data):
        return False
    rng = random.Random(20240)
    for _ in range(_POINTS):
        qi, qj = _unit(rng), _unit(rng)
        body = {name: (rng.uniform(0.5, 1.5), rng.uniform(0.5, 1.5)) for name, _ in pairs.values()}
        here: dict[sp.Symbol, float] = {}
        swapped: dict[sp.Symbol, float] = {}
        for arg in kernel.inputs:
            if arg.name in ("qi", "qj"):
                a, b = (qi, qj) if arg.name == "qi" else (qj, qi)
                here.update(zip(arg.symbols, a))
                swapped.update(zip(arg.symbols, b))
            elif arg.name in pairs:
                name, r = pairs[arg.name]
                here[arg.symbols[0]] = body[name][r]
                swapped[arg.symbols[0]] = body[name][1 - r]
            elif arg.shared:
                for s in arg.symbols:
                    here[s] = swapped[s] = rng.uniform(0.5, 1.5)
            else:
                return False
        v, w = _evaluate(kernel, here), _evaluate(kernel, swapped)
        if v is None or w is None or abs(v - w) > _TOLERANCE * max(abs(v), abs(w), 1e-300):
            return False
    return True


def _sorted_cells(module: Module, t: TermLoop) -> bool:
    if t.loop.kind is not LoopKind.CUTOFF_PAIRS or t.quadratic or t.data or t.table:
        return False
    value = module.kernel(t.value)
    return isinstance(value, Kernel) and symmetric_pair(value, t.body_data)


#: Largest size of the row buffers of a split rows loop (`Fission`), which live on the stack:
#: one double per body and buffer.
STACK_BYTES = 64 * 1024


def _fission(module: Module, t: TermLoop) -> Fission | None:
    """The rows gradient loop split at its calls, when it has calls to split at and the row
    buffers fit in `STACK_BYTES`."""
    gradient = module.kernel(t.gradient)
    if not isinstance(gradient, Kernel):
        return None
    split = split_at_calls(gradient)
    if split is None or 8 * module.n * len(split.stores) > STACK_BYTES:
        return None
    return split


def layout_pass(module: Module) -> Module:
    """Mark the all-pairs terms that loop over rows (split at their calls where that lets the
    rest vectorise) and the cutoff terms on sorted cells."""
    terms = []
    for t in module.terms:
        rows = contiguous(t) and not t.quadratic
        terms.append(
            replace(
                t,
                rows=rows,
                sorted_cells=_sorted_cells(module, t),
                fission=_fission(module, t) if rows else None,
            )
        )
    return replace(module, terms=tuple(terms))
