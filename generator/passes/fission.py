"""Loop fission at calls: a pair kernel's inline loop split so that its call-free parts vectorise.

Input: a lowered `Kernel` (the gradient of a term laid out as rows). Output: a `Fission`, or
None when the kernel calls no libm function whose argument is free of calls.

gcc vectorises sqrt and division but, without -ffast-math, no libm function (exp, log, sin,
...): one such call in a loop body keeps the whole body, square roots and divisions included,
one pair at a time. Split into three loops over the same partners, the first and the last are
free of those calls:

1. the call-free temporaries that the calls' arguments and the later part need; it writes each
   call's argument, and each temporary the later part reads that costs a square root, a
   division or a call to recompute, into a row buffer;
2. the calls, each applied in place to its buffer;
3. the outputs, reading the buffers, and recomputing the cheap temporaries (sums and products
   of the inputs) rather than storing them.

Each pair's operations stay the same IEEE operations on the same operands; only the row's sums,
a SIMD reduction once the loop vectorises, are added in another order.

Example:
    >>> import sympy as sp
    >>> from s2gen.ir import Argument, KernelDef, Output
    >>> from s2gen.passes import lower
    >>> a, b = sp.symbols("qi_0 qj_0", real=True)
    >>> r = sp.sqrt((a - b) ** 2)
    >>> k = lower(KernelDef("k", "", (Argument("qi", (a,)), Argument("qj", (b,))),
    ...                     (Output("gi", (sp.exp(-r) / r,)),)))
    >>> f = split_at_calls(k)
    >>> [str(e) for _, e in f.stores], [str(c) for c in f.calls]
    (['x0', '-x0'], ['None', 'exp(fission_arg)'])
"""

from __future__ import annotations

import sympy as sp

from s2gen.ir import Assignment, Fission, Kernel
from s2gen.passes.opcount import profile

__all__ = ["split_at_calls"]

#: Functions that gcc vectorises without -ffast-math (fabs is a bit operation): not split at.
_INLINE = (sp.Abs,)


def _calls(e: sp.Basic) -> list[sp.Expr]:
    """The calls of one-argument functions in `e` (innermost first, in a stable order)."""
    found: list[sp.Expr] = []
    for sub in sp.postorder_traversal(e):
        if (
            isinstance(sub, sp.Function)
            and not isinstance(sub, _INLINE)
            and len(sub.args) == 1
            and sub not in found
        ):
            found.append(sub)
    return found


def _costly(e: sp.Basic) -> bool:
    """Whether recomputing `e` from its operands costs more than additions and products."""
    ops = profile([e])
    return ops.div + ops.sqrt + ops.call > 0


def split_at_calls(kernel: Kernel) -> Fission | None:
    """The three loops of `kernel`'s inline body (see the module), or None if it has no call to
    split at."""
    temps = {a.temp: a.expr for a in kernel.assignments if a.temp is not None}
    order = [a.temp for a in kernel.assignments if a.temp is not None]
    # temporaries whose value depends on a call
    tainted: set[sp.Symbol] = set()
    for t in order:
        if _calls(temps[t]) or temps[t].free_symbols & tainted:
            tainted.add(t)
    split: list[sp.Expr] = []
    for a in kernel.assignments:
        for c in _calls(a.expr):
            arg = c.args[0]
            if not _calls(arg) and not arg.free_symbols & tainted and c not in split:
                split.append(c)
    if not split:
        return None
    results = {c: sp.Symbol(f"fission_call{k}", real=True) for k, c in enumerate(split)}
    rewritten = [Assignment(a.temp, a.output, a.expr.xreplace(results)) for a in kernel.assignments]
    early = {t for t in order if t not in tainted}
    # the last loop: the outputs and what they need; an early temporary that is costly to
    # recompute is read from a buffer instead
    stored: list[sp.Symbol] = []
    late: set[sp.Symbol] = set()
    rewritten_expr = {a.temp: a.expr for a in rewritten if a.temp is not None}
    pending = [s for a in rewritten if a.temp is None for s in a.expr.free_symbols]
    while pending:
        s = pending.pop()
        if s in late or s in stored or s not in rewritten_expr:
            continue
        if s in early and _costly(rewritten_expr[s]):
            stored.append(s)
            continue
        late.add(s)
        pending.extend(rewritten_expr[s].free_symbols)
    stored.sort(key=order.index)
    # the first loop: what the stored temporaries and the calls' arguments need
    first: set[sp.Symbol] = set()
    pending = list(stored) + [s for c in split for s in c.args[0].free_symbols]
    while pending:
        s = pending.pop()
        if s in first or s not in temps:
            continue
        first.add(s)
        pending.extend(temps[s].free_symbols)
    stores = tuple((s, s) for s in stored) + tuple((results[c], c.args[0]) for c in split)
    calls = (None,) * len(stored) + tuple(c.func(Fission.ARG) for c in split)
    return Fission(
        first=tuple(a for a in kernel.assignments if a.temp in first),
        stores=stores,
        calls=calls,
        last=tuple(a for a in rewritten if a.temp is None or a.temp in late),
    )
