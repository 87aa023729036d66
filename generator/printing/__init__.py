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

from s2gen.ir import Argument, Kernel, Module, TermLoop

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
class PrintedTerm:
    """A structured term as text: kernels, member/data tables, and the calls a loop makes.

    `loop` is one of "bodies", "body_list", "all_pairs", "chain", "pair_list". C tables are
    (type, name, length, rows of literals); NumPy setup lines define index and data arrays.
    """

    index: int
    loop: str
    count: int
    value: PrintedKernel
    gradient: PrintedKernel
    c_tables: tuple[tuple[str, str, int, tuple[str, ...]], ...]
    c_value_call: str
    c_gradient_call: str
    py_setup: tuple[str, ...]
    py_value_call: str
    py_gradient_call: str
    py_index: tuple[str, ...]  # index arrays of the roles, to scatter gradients
    cutoff: str = ""  # round-trip literal of the cutoff distance ("" without cutoff)
    rc2: str = ""  # its square
    cells: int = 0  # neighbour-list cells per axis


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
    work_base: int
    work_size: int
    general: bool  # V has a general (unstructured) part with its own kernels
    uniform_mass: bool  # all M_ii are one expression: the inertia kernel returns it once
    yoshida: tuple[str, str, str]  # triple-jump coefficients (round-trip literals)
    neighbour_lists: bool  # some pair term has a cutoff (cell lists are emitted)
    system_kernels: tuple[PrintedKernel, ...]
    body_kernels: tuple[PrintedKernel, ...]
    terms: tuple[PrintedTerm, ...]


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


def print_kernel(kernel: Kernel, system: bool) -> PrintedKernel:
    """Print one lowered kernel for both languages (`system`: positions are the global q)."""
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


def _rows(values: list[str], per_row: int = 6) -> tuple[str, ...]:
    return tuple(", ".join(values[k : k + per_row]) for k in range(0, len(values), per_row))


_LOOPS = {
    ("body", "all"): "bodies",
    ("body", "list"): "body_list",
    ("pair", "all"): "all_pairs",
    ("pair", "chain"): "chain",
    ("pair", "list"): "pair_list",
}


def _print_term(name: str, t: TermLoop) -> PrintedTerm:
    """Tables and call strings of one term loop (loop variables: m member, i and j bodies)."""
    pre, up = f"{name}_t{t.index}", f"T{t.index}"
    loop = _LOOPS[(t.kind, t.select)]
    tables: list[tuple[str, str, int, tuple[str, ...]]] = []
    setup: list[str] = []
    roles = ("i",) if t.kind == "body" else ("i", "j")
    if t.select == "list":
        for r, role in enumerate(roles):
            idx = [str(mem[r]) for mem in t.members]
            tables.append(("int", f"{pre}_{role}", t.count, _rows(idx, 16)))
            setup.append(f"{up}_{role.upper()} = numpy.array([{', '.join(idx)}], dtype=int)")
    elif loop == "bodies":
        setup.append(f"{up}_I = numpy.arange(NBODIES)")
    elif loop == "chain":
        setup += [f"{up}_I = numpy.arange(NBODIES - 1)", f"{up}_J = {up}_I + 1"]
    elif t.cutoff is None:
        setup.append(f"{up}_I, {up}_J = numpy.triu_indices(NBODIES, 1)")
    c_args, py_args = ["p"], ["p"]
    for role in roles:
        c_args.append(f"q + 3 * {role}")
        py_args.append(f"q[{up}_{role.upper()}]")
    for dname, width, values in t.data:
        lits = [repr(float(v)) for v in values]
        tables.append(("double", f"{pre}_{dname}", len(values), _rows(lits)))
        arr = f"numpy.array([{', '.join(lits)}])"
        setup.append(f"{up}_{dname.upper()} = {arr}" + ("" if width == 1 else ".reshape(-1, 3)"))
        c_args.append(f"{pre}_{dname}[m]" if width == 1 else f"{pre}_{dname} + 3 * m")
        py_args.append(f"{up}_{dname.upper()}")
    grads = ["gb"] if t.kind == "body" else ["gi", "gj"]
    return PrintedTerm(
        index=t.index,
        loop=loop,
        count=t.count,
        value=print_kernel(t.value, False),
        gradient=print_kernel(t.gradient, False),
        c_tables=tuple(tables),
        c_value_call=f"{name}_k_t{t.index}_value({', '.join(c_args)}, &v)",
        c_gradient_call=f"{name}_k_t{t.index}_gradient({', '.join(c_args + grads)})",
        py_setup=tuple(setup),
        py_value_call=f"_k_t{t.index}_value({', '.join(py_args)})",
        py_gradient_call=f"_k_t{t.index}_gradient({', '.join(py_args)})",
        py_index=tuple(f"{up}_{role.upper()}" for role in roles),
        cutoff="" if t.cutoff is None else repr(float(t.cutoff)),
        rc2="" if t.cutoff is None else repr(float(t.cutoff) ** 2),
        cells=t.cells,
    )


def _yoshida() -> tuple[str, str, str]:
    """Yoshida's triple jump: g1 = 1/(2 - 2^(1/3)), g2 = 1 - 2 g1 (so the steps add up to h)."""
    g1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
    g2 = 1.0 - 2.0 * g1
    return repr(g1), repr(g2), repr(g1)


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
        work_base=module.work_base,
        work_size=module.work_size,
        general=any(k.name == "gradient" for k in module.system_kernels),
        yoshida=_yoshida(),
        neighbour_lists=any(t.cutoff is not None for t in module.terms),
        uniform_mass=module.n > 1 and module.system_kernels[0].outputs[0].size == 1,
        system_kernels=tuple(print_kernel(k, True) for k in module.system_kernels),
        body_kernels=tuple(print_kernel(k, False) for k in module.body_kernels),
        terms=tuple(_print_term(module.name, t) for t in module.terms if t.count > 0),
    )
