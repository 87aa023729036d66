"""C99 and NumPy printers: lowered kernels become text records for the templates.

Input: a `Module` (IR). Output: a `PrintedModule` of plain strings, numbers and tuples, the only
thing the templates see. Symbols are mapped to array slots by overriding the printers'
`_print_Symbol` (no string replacement): array input `q` with symbols (q0, q1, q2) prints as
`q[0]`, `q[1]`, `q[2]` in C and `q[..., 0]` ... in NumPy (so per-body kernels vectorize over
bodies); the system kernels index positions as `q[3*i + c]` in C and `q[i, c]` in NumPy.

Example:
    >>> import sympy as sp
    >>> x = sp.Symbol("x", real=True)
    >>> CPrinter({x: "q[0]"}).doprint(sp.sqrt(x) + sp.pi)
    'sqrt(q[0]) + 3.14159265358979323846'
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.numpy import NumPyPrinter

from .ir import Argument, Kernel, Module

__all__ = ["CPrinter", "PrintedKernel", "PrintedModule", "PyPrinter", "print_module"]


class CPrinter(C99CodePrinter):
    """C99 printer with symbols mapped to argument slots; pi as a literal (M_PI is POSIX)."""

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__()
        self._names = names

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        name = self._names.get(expr)
        return name if name is not None else super()._print_Symbol(expr)

    def _print_Pi(self, expr: sp.Expr) -> str:
        return "3.14159265358979323846"


class PyPrinter(NumPyPrinter):
    """NumPy printer with symbols mapped to argument slots (`numpy.` qualified calls)."""

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__({"fully_qualified_modules": True})
        self._names = names

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        name = self._names.get(expr)
        return name if name is not None else super()._print_Symbol(expr)


@dataclass(frozen=True)
class PrintedKernel:
    """One kernel as text: C signature and body lines, NumPy signature and body lines."""

    name: str
    doc: str
    c_params: str
    c_lines: tuple[str, ...]
    py_params: str
    py_lines: tuple[str, ...]
    ops_before: int
    ops_after: int
    temporaries: int


@dataclass(frozen=True)
class PrintedModule:
    """Everything the templates lay out for one system (strings, numbers, tuples)."""

    name: str
    upper: str
    spec_hash: str
    origin: str
    n: int
    n3: int
    npairs: int
    coupled: bool
    parameters: tuple[tuple[str, str], ...]  # (name, value as a round-trip literal)
    pair_i: tuple[int, ...]
    pair_j: tuple[int, ...]
    work_size: int
    system_kernels: tuple[PrintedKernel, ...]
    body_kernels: tuple[PrintedKernel, ...]


def _system_names(arg: Argument, c: bool) -> dict[sp.Symbol, str]:
    """Slots of a system kernel's argument: positions are (n, 3) in NumPy, flat in C."""
    if arg.name == "q" and not c:
        return {s: f"q[{k // 3}, {k % 3}]" for k, s in enumerate(arg.symbols)}
    return {s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)}


def _names(kernel: Kernel, system: bool, c: bool) -> dict[sp.Symbol, str]:
    names: dict[sp.Symbol, str] = {}
    for arg in kernel.inputs:
        if arg.scalar:
            names[arg.symbols[0]] = arg.name
        elif system:
            names.update(_system_names(arg, c))
        elif c:
            names.update({s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)})
        else:
            names.update({s: f"{arg.name}[..., {k}]" for k, s in enumerate(arg.symbols)})
    return names


def _used(kernel: Kernel) -> set[sp.Symbol]:
    used: set[sp.Symbol] = set()
    for a in kernel.assignments:
        used |= a.expr.free_symbols
    return used


def _c_kernel(kernel: Kernel, system: bool) -> tuple[str, tuple[str, ...]]:
    pr = CPrinter(_names(kernel, system, c=True))
    params = [
        f"const double {a.name}" if a.scalar else f"const double *restrict {a.name}"
        for a in kernel.inputs
    ] + [f"double *restrict {o.name}" for o in kernel.outputs]
    used = _used(kernel)
    lines = [f"(void){a.name};" for a in kernel.inputs if not set(a.symbols) & used]
    for a in kernel.assignments:
        rhs = pr.doprint(a.expr)
        if a.temp is not None:
            lines.append(f"const double {a.temp} = {rhs};")
        else:
            assert a.output is not None
            lines.append(f"{a.output[0]}[{a.output[1]}] = {rhs};")
    return ", ".join(params), tuple(lines)


def _py_kernel(kernel: Kernel, system: bool) -> tuple[str, tuple[str, ...]]:
    pr = PyPrinter(_names(kernel, system, c=False))
    params = ", ".join(a.name for a in kernel.inputs)
    slots: dict[tuple[str, int], str] = {}
    lines = []
    for a in kernel.assignments:
        rhs = pr.doprint(a.expr)
        if a.temp is not None:
            lines.append(f"{a.temp} = {rhs}")
        else:
            assert a.output is not None
            slots[a.output] = rhs
    results = []
    for out in kernel.outputs:
        comps = [slots[(out.name, k)] for k in range(out.size)]
        if out.scalar:
            lines.append(f"{out.name} = {comps[0]}")
        elif system:
            lines.append(f"{out.name} = numpy.array([{', '.join(comps)}], dtype=float)")
        else:
            lines.append(f"{out.name} = _stack({', '.join(comps)})")
        results.append(out.name)
    lines.append(f"return {', '.join(results)}")
    return params, tuple(lines)


def _print_kernel(kernel: Kernel, system: bool) -> PrintedKernel:
    c_params, c_lines = _c_kernel(kernel, system)
    py_params, py_lines = _py_kernel(kernel, system)
    return PrintedKernel(
        name=kernel.name,
        doc=kernel.doc,
        c_params=c_params,
        c_lines=c_lines,
        py_params=py_params,
        py_lines=py_lines,
        ops_before=kernel.ops_before,
        ops_after=kernel.ops_after,
        temporaries=sum(1 for a in kernel.assignments if a.temp is not None),
    )


def print_module(module: Module) -> PrintedModule:
    """Print every kernel of a module for both languages."""
    return PrintedModule(
        name=module.name,
        upper=module.name.upper(),
        spec_hash=module.spec_hash,
        origin=module.origin,
        n=module.n,
        n3=3 * module.n,
        npairs=len(module.pairs),
        coupled=module.coupled,
        parameters=tuple(
            (p, repr(float(v))) for p, v in zip(module.parameter_names, module.parameter_values)
        ),
        pair_i=tuple(i for i, _ in module.pairs),
        pair_j=tuple(j for _, j in module.pairs),
        work_size=module.work_size,
        system_kernels=tuple(_print_kernel(k, True) for k in module.system_kernels),
        body_kernels=tuple(_print_kernel(k, False) for k in module.body_kernels),
    )
