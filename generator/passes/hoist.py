"""Pass `hoist`: what depends only on parameters, or on parameters and a member's data, is
computed once per call instead of at every evaluation.

Input: a `Module` whose system and term kernels are lowered (cse'd). Output: the same module in
which every subexpression of those kernels that depends only on the parameters (stage 0) is a
context constant `cc[k]`, computed once per call by the new kernel `context`, and every
subexpression that depends only on the parameters and a term member's data (stage 1) is a slot
of that term's member table `tab[k]`, computed once per call and member by the new kernel
`t<k>_table`; the kernels read them instead (inputs `cc` and `tab`). Products and sums whose
factors have mixed stages are regrouped first, so that, e.g., `4*eps*sigma**12/r2**7` hoists
`4*eps*sigma**12`. Parameters stay runtime inputs: nothing is folded to a number.

A kernel takes part when its definition says which inputs are parameters and data
(`KernelDef.stages`); the generic kernels of the equations do not.

Per-body data ([data], stage 2 in a term kernel's definition) count as a member's data (stage
1) where that saves work (`member_data`): on a term over fixed members whose loop gathers its
bodies by index (a list, the chain, the ring, every body), so that, e.g., `k*ci*cj` or a mixing
rule `sqrt(ei*ej)` is computed once per member and call and read as one contiguous slot instead
of two gathered loads and the operations at every evaluation. They stay per evaluation on
all-pairs terms laid out as rows, which read them contiguously and would otherwise stream a
table of n(n-1)/2 rows per evaluation, and on cutoff terms, whose members are found per call.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> m = lower_system(builtin("molecular"))
    >>> [k.name for k in m.kernels][:2], m.constants > 0
    (['context', 'inertia'], True)
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import sympy as sp

from s2gen.ir import Argument, Assignment, Kernel, KernelDef, Module, Output, TermLoop
from s2gen.passes.cse import lower_kernel
from s2gen.passes.layout import contiguous

__all__ = ["CONSTANT", "TABLE", "hoist_pass", "member_data"]

#: Names of the hoisted symbols: context constants cc_k, member-table slots tab_k.
CONSTANT, TABLE = "cc", "tab"
_NUMBER = -1  # the stage of a number: free


@dataclass
class _Hoister:
    """Collects the hoisted expressions of one module (context) or one term (table)."""

    prefix: str
    exprs: list[sp.Expr] = field(default_factory=list)
    index: dict[sp.Expr, int] = field(default_factory=dict)

    def symbol(self, expr: sp.Expr) -> sp.Symbol:
        """The slot of `expr` (shared with an identical expression hoisted before)."""
        if expr not in self.index:
            self.index[expr] = len(self.exprs)
            self.exprs.append(expr)
        return sp.Symbol(f"{self.prefix}_{self.index[expr]}", real=True)

    @property
    def symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(sp.Symbol(f"{self.prefix}_{k}", real=True) for k in range(len(self.exprs)))


def _trivial(expr: sp.Expr) -> bool:
    """A lone symbol or a number: read directly, not worth a slot."""
    return bool(expr.is_Symbol or expr.is_Number)


class _Stager:
    """Rewrites one kernel: hoists maximal stage-0 and stage-1 subexpressions."""

    def __init__(
        self,
        stage: dict[sp.Symbol, int],
        context: _Hoister,
        table: _Hoister | None,
        expansion: dict[sp.Symbol, sp.Expr],
    ) -> None:
        self.stage = stage
        self.context = context
        self.table = table
        self.expansion = expansion  # temporaries of lower stage, in input symbols

    def level(self, expr: sp.Expr) -> int:
        symbols = expr.free_symbols
        return max((self.stage.get(s, 2) for s in symbols), default=_NUMBER)

    def cut(self, expr: sp.Expr) -> sp.Expr:
        """Replace a whole low-stage expression by its hoisted symbol (temporaries of low stage
        are expanded first; what is too simple for a slot is written out)."""
        level = self.level(expr)
        if level > 1 or level == _NUMBER:
            return expr
        full = expr.xreplace(self.expansion)
        hoister = self.context if level == 0 else self.table
        if hoister is None or _trivial(full):
            return full
        return hoister.symbol(full)

    def rewrite(self, expr: sp.Expr) -> sp.Expr:
        """`expr` with its maximal low-stage parts hoisted (mixed Add/Mul args regrouped)."""
        if self.level(expr) <= 1:
            return self.cut(expr)
        if not expr.args:
            return expr
        if expr.is_Add or expr.is_Mul:
            low: dict[int, list[sp.Expr]] = {_NUMBER: [], 0: [], 1: []}
            rest: list[sp.Expr] = []
            for arg in expr.args:
                level = self.level(arg)
                if level <= 1:
                    low[level].append(arg)
                else:
                    rest.append(self.rewrite(arg))
            op = expr.func
            parts = list(rest)
            if low[0] or low[1]:  # numbers join the hoisted group: 24*eps*sigma**6 is one slot
                parts.append(self.cut(op(*low[_NUMBER], *low[0], *low[1])))
            else:
                parts += low[_NUMBER]
            return op(*parts)
        return expr.func(*(self.rewrite(a) for a in expr.args))


def member_data(t: TermLoop) -> bool:
    """Whether the per-body data of term `t` are hoisted with its member's data: its members
    are fixed and its loop gathers them (see the module's docstring).

    Example:
        >>> from s2gen.ir import Loop, LoopKind
        >>> chain = TermLoop(0, Loop(LoopKind.CHAIN, 3), (), "t0_value", "t0_gradient")
        >>> rows = TermLoop(1, Loop(LoopKind.ALL_PAIRS, 6), (), "t1_value", "t1_gradient")
        >>> member_data(chain), member_data(rows)
        (True, False)
    """
    return t.loop.kind.fixed and not contiguous(t)


def _stages(kernel: Kernel | KernelDef, per_member: bool) -> dict[str, int]:
    """Input name -> stage of a staged kernel; per-body data (listed at stage 2) at stage 1
    when `per_member`."""
    stages = dict(kernel.stages or ())
    if per_member:
        stages = {name: 1 if level == 2 else level for name, level in stages.items()}
    return stages


def _stage_kernel(
    kernel: Kernel, context: _Hoister, table: _Hoister | None, per_member: bool
) -> tuple[Kernel, bool]:
    """The kernel with hoisted parts read from cc and tab; True when something was hoisted."""
    stages = _stages(kernel, per_member)
    stage: dict[sp.Symbol, int] = {}
    for arg in kernel.inputs:
        for s in arg.symbols:
            stage[s] = stages.get(arg.name, 2)
    expansion: dict[sp.Symbol, sp.Expr] = {}
    stager = _Stager(stage, context, table, expansion)
    out: list[Assignment] = []
    before = (len(context.exprs), len(table.exprs) if table else 0)
    for a in kernel.assignments:
        level = stager.level(a.expr)
        if a.temp is not None and level <= 1 and (level == 0 or table is not None):
            # a whole temporary of low stage: its uses read the hoisted value
            expansion[a.temp] = a.expr.xreplace(expansion)
            stage[a.temp] = level
            continue
        out.append(Assignment(a.temp, a.output, stager.rewrite(a.expr)))
    # temporaries of low stage that survive inside kept expressions are cut where used
    hoisted = (len(context.exprs), len(table.exprs) if table else 0) != before or len(out) < len(
        kernel.assignments
    )
    return replace(kernel, assignments=tuple(out)), hoisted


def _with_inputs(kernel: Kernel, context: _Hoister, table: _Hoister | None) -> Kernel:
    """The kernel taking `cc` and `tab` when it reads them (indexed as computed), and no
    longer the parameters or data it no longer reads."""
    used: set[sp.Basic] = set()
    for a in kernel.assignments:
        used |= a.expr.free_symbols
    stages = dict(kernel.stages or ())
    kept = [a for a in kernel.inputs if a.name not in stages or set(a.symbols) & used]
    if set(context.symbols) & used:
        kept.append(Argument(CONSTANT, context.symbols, shared=True))
    if table is not None and set(table.symbols) & used:
        kept.append(Argument(TABLE, table.symbols))
    return replace(kernel, inputs=tuple(kept))


def hoist_pass(module: Module) -> Module:
    """Hoist stage-0 and stage-1 subexpressions of the module's staged kernels."""
    staged = [k for k in module.kernels if isinstance(k, Kernel) and k.stages is not None]
    if not staged:
        return module
    context = _Hoister(CONSTANT)
    tables = {t.index: _Hoister(TABLE) for t in module.terms}
    owner = {name: t for t in module.terms for name in (t.value, t.gradient)}
    rewritten: dict[str, Kernel] = {}
    for k in staged:
        term = owner.get(k.name)
        per_member = term is not None and member_data(term)
        table = tables[term.index] if term is not None and (term.data or per_member) else None
        new, _ = _stage_kernel(k, context, table, per_member)
        rewritten[k.name] = new
    kernels: list[KernelDef | Kernel] = []
    if context.exprs:
        params = next(a for a in staged[0].inputs if a.name == "p")
        kernels.append(
            lower_kernel(
                KernelDef(
                    "context",
                    "constants of the kernels that depend only on the parameters (once per call)",
                    (params,),
                    (Output(CONSTANT, tuple(context.exprs)),),
                    system=True,
                )
            )
        )
    terms: list[TermLoop] = []
    for t in module.terms:
        table = tables[t.index]
        if table.exprs:
            value = rewritten[t.value]
            stages = _stages(value, member_data(t))
            inputs = tuple(a for a in value.inputs if stages.get(a.name, 2) < 2)
            kernels.append(
                lower_kernel(
                    KernelDef(
                        f"t{t.index}_table",
                        f"term {t.index}: what depends only on parameters and the member's data "
                        "(once per call and member)",
                        inputs,
                        (Output(TABLE, tuple(table.exprs)),),
                    )
                )
            )
        terms.append(replace(t, table=len(table.exprs)))
    for k in module.kernels:
        if k.name in rewritten:
            owner_term = owner.get(k.name)
            table = tables[owner_term.index] if owner_term is not None else None
            kernels.append(_with_inputs(rewritten[k.name], context, table))
        else:
            kernels.append(k)
    return replace(module, kernels=tuple(kernels), terms=tuple(terms), constants=len(context.exprs))
