"""Pass `reciprocal`: a body's mass that a kernel only divides by is read as its inverse.

Input: a `Module` whose kernels are `KernelDef`s. The body kernels take the body's diagonal mass
M_ii as the scalar input `m` (bound to the context's masses). When every occurrence of m in a
kernel's outputs is a negative power of it (q x g / m, h / (2 m), ...), the kernel takes `mi` =
1 / m instead, bound to the inverse masses the context computes once per call: the kernel
multiplies where it divided, one division per body and evaluation fewer (the explicit VI, RATTLE
and the vector field of uncoupled bodies divide by m at every step). A kernel that also
multiplies by m (kinetic energy, momentum) is left alone.

Example:
    >>> import sympy as sp
    >>> from s2gen.ir import Argument, Output
    >>> m, x = sp.Symbol("m", positive=True), sp.Symbol("x", real=True)
    >>> k = KernelDef("k", "", (Argument("m", (m,), True), Argument("x", (x,), True)),
    ...               (Output("y", (x / (2 * m),), True),))
    >>> r = inverted(k)
    >>> [a.name for a in r.inputs], r.outputs[0].exprs
    (['mi', 'x'], (mi*x/2,))
"""

from __future__ import annotations

import functools
from dataclasses import replace

import sympy as sp

from s2gen.ir import Argument, KernelDef, Module, Output

__all__ = ["INVERSE", "MASS", "inverted", "reciprocal_pass"]

#: The body-mass input, and the name of its inverse.
MASS, INVERSE = "m", "mi"


def _only_divides(expr: sp.Basic, m: sp.Symbol) -> bool:
    """True when m occurs in expr only as m**k with k < 0 (and does occur)."""
    if expr == m:
        return False
    if isinstance(expr, sp.Pow) and expr.base == m:
        return bool(expr.exp.is_negative)
    return all(_only_divides(a, m) for a in expr.args if a.has(m))


@functools.lru_cache(maxsize=1024)
def inverted(kdef: KernelDef) -> KernelDef:
    """`kdef` with its mass input `m` replaced by `mi` = 1/m, when it only divides by m."""
    masses = [a for a in kdef.inputs if a.name == MASS and a.scalar]
    if not masses:
        return kdef
    m = masses[0].symbols[0]
    exprs = [sp.sympify(e) for o in kdef.outputs for e in o.exprs]
    if not any(e.has(m) for e in exprs) or not all(_only_divides(e, m) for e in exprs if e.has(m)):
        return kdef
    mi = sp.Symbol(INVERSE, positive=True)
    inputs = tuple(Argument(INVERSE, (mi,), True) if a is masses[0] else a for a in kdef.inputs)
    outputs = tuple(
        Output(o.name, tuple(sp.sympify(e).subs(m, 1 / mi) for e in o.exprs), o.scalar)
        for o in kdef.outputs
    )
    return replace(kdef, inputs=inputs, outputs=outputs)


def reciprocal_pass(module: Module) -> Module:
    """Every body kernel that only divides by its mass takes the inverse mass instead."""
    kernels = tuple(inverted(k) if isinstance(k, KernelDef) else k for k in module.kernels)
    return replace(module, kernels=kernels)
