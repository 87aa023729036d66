"""NumPy's integrate_batch(): what the batch part of the NumPy module prints.

Input: a lowered sphere `Module` whose parts carry the batch part (`s2gen.parts.batch`).
Output: the record the batch part's NumPy sections read (`m.py_batch`): why the module has
no members' code (or None), the potential's general kernels printed for members, the first
lines of the members' potential and gradient and the methods covered. Which sections lay it
out (the members' code or the refusal, the field of a diagonal or dense M) is chosen with
the other sections (`s2gen.printing.sections.sections`).

The members' code lives in the emitted module, beside the one-member functions it mirrors,
because what it calls (the term loops, their member tables, the general kernels, the field's
solve) is the module's own and differs per system; a driver outside would have to rebuild
that structure from the IR. It reuses the one-member kernels unchanged: they work on arrays
(..., 3) per body, so the members ride on an axis between the body and the component,
states of shape (NBODIES, K, 3), and every printed call site (`q[T1_I]`, `(1.0 / md)`) reads
the same text with per-member constants of shape (..., K). Only the general potential's
kernels, which index q by body and build their output with numpy.array, are printed again
for members (`py_member_kernel`). Newton's iteration of a dense M's VI runs on all members
at once, each under its own mask: a member stops updating once its own test holds (or fails
alone), so it takes exactly the iterations integrate() takes for it.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> b = print_numpy_batch(lower_system(builtin("double_pendulum").with_batch()))
    >>> b["refusal"], b["methods"][:4]
    (None, ('METHOD_VI', 'METHOD_VI4', 'METHOD_VI6', 'METHOD_VI8'))
    >>> b["potential_start"]
    'total = numpy.broadcast_to(_kb_potential(q, cc), q.shape[1:2])'
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Call, Kernel, Module
from s2gen.parts.batch import numpy_batch_refusal
from s2gen.printing.numpy import PyPrinter, py_binding

__all__ = ["print_numpy_batch", "py_member_kernel"]

#: The VI family (explicit with a diagonal M) and the fixed-step Runge-Kutta methods, by the
#: constants of the emitted module
_VI = ("METHOD_VI", "METHOD_VI4", "METHOD_VI6", "METHOD_VI8")
_RK = ("METHOD_RK2", "METHOD_RK2_PROJ", "METHOD_RK3", "METHOD_RK4")


def py_member_kernel(kernel: Kernel) -> tuple[str, tuple[str, ...]]:
    """(parameter list, body lines) of a system kernel (the general potential or gradient)
    for K members at once: the state q of shape (NBODIES, K, 3) reads as q[i, ..., c], the
    parameters p (K, NPARAMS) as p[..., k], the constants cc (one row of K per constant) as
    cc[k]; a vector output is stacked as (size, K).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> k = lower_system(builtin("double_pendulum")).kernel("potential")
        >>> py_member_kernel(k)[1][0]
        'v = cc[2]*(cc[0]*q[0, ..., 2] + cc[1]*q[1, ..., 2])'
    """
    names = {}
    for arg in kernel.inputs:
        if arg.scalar:
            names[arg.symbols[0]] = arg.name
        elif arg.name == "p":  # the members' parameters, shape (K, NPARAMS)
            names.update({s: f"p[..., {k}]" for k, s in enumerate(arg.symbols)})
        elif arg.name == "q":
            names.update({s: f"q[{k // 3}, ..., {k % 3}]" for k, s in enumerate(arg.symbols)})
        else:
            names.update({s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)})
    pr = PyPrinter(names)
    slots: dict[tuple[str, int], str] = {}
    lines = []
    for a in kernel.assignments:
        rhs = pr.doprint(a.expr)
        if a.temp is not None:
            lines.append(f"{a.temp} = {rhs}")
        else:
            assert a.output is not None
            slots[a.output] = rhs
    for out in kernel.outputs:
        comps = [slots[(out.name, k)] for k in range(out.size)]
        rhs = comps[0] if out.scalar else f"_members({', '.join(comps)})"
        lines.append(f"{out.name} = {rhs}")
    lines.append(f"return {', '.join(o.name for o in kernel.outputs)}")
    return ", ".join(a.name for a in kernel.inputs), tuple(lines)


def _member_call(call: Call) -> str:
    return f"_kb_{call.kernel}({', '.join(py_binding(b) for b in call.inputs)})"


def print_numpy_batch(module: Module) -> dict[str, Any]:
    """The batch part's record for the NumPy template (the same keys, empty values, when the
    module has no batch part)."""
    empty: dict[str, Any] = {
        "refusal": None,
        "kernels": (),
        "potential_start": "",
        "gradient_start": "",
        "methods": (),
    }
    if "batch" not in module.parts:
        return empty
    why = numpy_batch_refusal(module)
    if why is not None:
        return {**empty, "refusal": why}
    general = bool(dict(module.facts).get("general", False))
    calls = {c.site: c for c in module.calls}
    kernels = tuple(
        {"name": name, "params": params, "lines": lines}
        for name in (("potential", "gradient") if general else ())
        for params, lines in (py_member_kernel(module.kernel(name)),)
    )
    n = module.n
    if general:
        potential = f"total = numpy.broadcast_to({_member_call(calls['potential'])}, q.shape[1:2])"
        members = f"{_member_call(calls['gradient'])}.reshape({n}, 3, -1).transpose(0, 2, 1)"
        gradient = f"g = numpy.array(numpy.broadcast_to({members}, ({n}, q.shape[1], 3)))"
    else:
        potential = "total = numpy.zeros(q.shape[1])"
        gradient = f"g = numpy.zeros(({n}, q.shape[1], 3))"
    return {
        "refusal": None,
        "kernels": kernels,
        "potential_start": potential,
        "gradient_start": gradient,
        "methods": _VI + _RK,
    }
