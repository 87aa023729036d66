"""The NumPy printer: lowered kernels and term set-up as Python text.

Input: IR records (`Kernel`, `TermLoop`, `Call`). Output: strings and tuples of lines for the
templates. Per-body and per-pair kernels take arrays of shape (..., 3) and work on all members
at once: an array input `q` prints as `q[..., 0]` ...; a system kernel's positions as `q[i, c]`.

Example:
    >>> import sympy as sp
    >>> x = sp.Symbol("x", real=True)
    >>> PyPrinter({x: "q[..., 0]"}).doprint(sp.sqrt(x))
    'numpy.sqrt(q[..., 0])'
"""

from __future__ import annotations

import math
from typing import Any, assert_never

import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from s2gen.bindings import (
    Binding,
    BodyDatum,
    BodyNumber,
    ContextArray,
    Element,
    Index,
    InertiaDatum,
    Local,
    MemberSlot,
    Product,
    Shifted,
    Slot,
    TermDatum,
    TermTable,
)
from s2gen.ir import Call, Drive, Kernel, Module, ModuleKind, TermLoop
from s2gen.printing.c import EXACT_INTEGER, ExactIntegers, LiteralError, double_literal
from s2gen.terms import Enumeration

__all__ = [
    "PyPrinter",
    "py_binding",
    "py_call",
    "py_data_setup",
    "py_docstring",
    "py_drive",
    "py_inertia_setup",
    "py_kernel",
    "py_quad",
    "py_table_names",
    "py_term_gradient",
    "py_term_setup",
]


class PyPrinter(ExactIntegers, NumPyPrinter):
    """NumPy printer with symbols mapped to argument slots (`numpy.` qualified calls).

    Numbers print as the C printer's do: exact integers and rationals beyond 2**53 as their
    correctly rounded double, anything beyond the range of a double or complex an error.
    """

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__({"fully_qualified_modules": True})
        self._names = names

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        name = self._names.get(expr)
        return name if name is not None else super()._print_Symbol(expr)

    def _print_Rational(self, expr: sp.Rational) -> str:
        if abs(int(expr.p)) <= EXACT_INTEGER and int(expr.q) <= EXACT_INTEGER:
            return str(super()._print_Rational(expr))
        return double_literal(expr)

    def _print_Float(self, expr: sp.Float) -> str:
        if not math.isfinite(float(expr)):
            raise LiteralError(
                f"the number {sp.Float(expr, 4)} is beyond the range of a double (magnitude at "
                "most about 1.8e308)"
            )
        return str(super()._print_Float(expr))

    def _print_ImaginaryUnit(self, expr: sp.Expr) -> str:
        raise LiteralError("a complex number (I) cannot be printed as real NumPy arithmetic")


#: A system kernel's state arguments, arrays of shape (NBODIES, 3) in NumPy's code (its other
#: arrays, such as forces F and their Jacobian Fw, are flat)
_BODY_ROWS = ("q", "w")


def _slots(kernel: Kernel) -> dict[sp.Symbol, str]:
    names: dict[sp.Symbol, str] = {}
    for arg in kernel.inputs:
        if arg.scalar:
            names[arg.symbols[0]] = arg.name
        elif arg.shared:
            names.update({s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)})
        elif kernel.system and arg.name in _BODY_ROWS:
            names.update({s: f"{arg.name}[{k // 3}, {k % 3}]" for k, s in enumerate(arg.symbols)})
        elif kernel.system:
            names.update({s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)})
        else:
            names.update({s: f"{arg.name}[..., {k}]" for k, s in enumerate(arg.symbols)})
    return names


def py_kernel(kernel: Kernel) -> tuple[str, tuple[str, ...]]:
    """(parameter list, body lines) of a kernel as a Python function."""
    pr = PyPrinter(_slots(kernel))
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
        elif kernel.system:
            lines.append(f"{out.name} = numpy.array([{', '.join(comps)}], dtype=float)")
        else:
            lines.append(f"{out.name} = _stack({', '.join(comps)})")
        results.append(out.name)
    lines.append(f"return {', '.join(results)}")
    return params, tuple(lines)


#: Per-body arrays NumPy's code derives where C reads the context's copy (the inverse masses)
_DERIVED = {"mi": "(1.0 / md)"}
#: How NumPy indexes an array by a pair's bodies (a body's or a pair's slot is the whole array)
_PAIR_BODY = {Index.FIRST: "[PAIR_I]", Index.SECOND: "[PAIR_J]"}


def _table_name(term: int) -> str:
    return f"tab{term}"


def py_binding(b: Binding) -> str:
    """A bound argument as NumPy: the calls vectorize, so a slot or an entry at a body or a pair
    is the whole array, at a pair's body it is indexed by PAIR_I / PAIR_J, at a member's body
    by the term's index arrays.

    Example:
        >>> py_binding(MemberSlot(2, "j")), py_binding(Element("mi", Index.BODY, context=True))
        ('q[T2_J]', '(1.0 / md)')
    """
    if isinstance(b, Local):
        return b.vector or b.name
    if isinstance(b, ContextArray):
        return b.name
    if isinstance(b, Slot):
        return (b.vector or b.array) + _PAIR_BODY.get(b.index, "")
    if isinstance(b, MemberSlot):
        return f"q[T{b.term}_{b.body.upper()}]"
    if isinstance(b, Element):
        return _DERIVED.get(b.array, b.array) + _PAIR_BODY.get(b.index, "")
    if isinstance(b, Product):
        return " * ".join(py_binding(f) for f in b.factors)
    if isinstance(b, Shifted):
        return b.vector or f"{b.array}[{b.offset}:]"
    if isinstance(b, BodyNumber):
        return "INDEX"
    if isinstance(b, TermDatum):
        return f"T{b.term}_{b.name.upper()}"
    if isinstance(b, BodyDatum):
        return f"DATA_{b.name}[T{b.term}_{b.body.upper()}]"
    if isinstance(b, InertiaDatum):
        return f"INERTIA_{b.name.upper()}"
    if isinstance(b, TermTable):
        return _table_name(b.term)
    assert_never(b)


def py_call(call: Call) -> str:
    """The Python call expression of a call site: the inputs (the outputs are returned).

    Example:
        >>> from s2gen.ir import Call
        >>> py_call(Call("e", "energy", (Slot("q", 3, Index.BODY),), (Local("e"),)))
        '_k_energy(q)'
    """
    return f"_k_{call.kernel}({', '.join(py_binding(b) for b in call.inputs)})"


def _index_names(t: TermLoop) -> tuple[str, ...]:
    """The names of a term's member index arrays (T<k>_I, T<k>_J)."""
    return tuple(f"T{t.index}_{i.upper()}" for i in t.loop.kind.kind.indices)


def py_term_setup(t: TermLoop) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(module-level set-up lines, index array names) of a term: member index arrays (none for
    cutoff terms, whose pairs are found at each call) and data arrays.

    Example:
        >>> from s2gen.ir import Loop, LoopKind
        >>> py_term_setup(TermLoop(2, Loop(LoopKind.CHAIN, 3), (), "t2_value", "t2_gradient"))
        (('T2_I = numpy.arange(NBODIES - 1)', 'T2_J = T2_I + 1'), ('T2_I', 'T2_J'))
    """
    up = f"T{t.index}"
    rule = t.loop.kind.rule
    names = _index_names(t)
    setup: list[str] = []
    if rule.enumeration is Enumeration.TABLE:
        for r, name in enumerate(names):
            idx = ", ".join(str(mem[r]) for mem in t.loop.members)
            setup.append(f"{name} = numpy.array([{idx}], dtype=int)")
    elif rule.enumeration is Enumeration.SHIFTED:
        longest = 0 if rule.wrap else max(rule.shifts)
        first = f"numpy.arange(NBODIES - {longest})" if longest else "numpy.arange(NBODIES)"
        for name, s in zip(names, rule.shifts):
            base = first if name == names[0] else names[0]
            shifted = f"{base} + {s}" if s else base
            setup.append(
                f"{name} = ({shifted}) % NBODIES" if rule.wrap and s else f"{name} = {shifted}"
            )
    elif rule.enumeration is Enumeration.TRIANGLE:
        setup.append(f"{', '.join(names)} = numpy.triu_indices(NBODIES, 1)")
    for dname, width, values in t.data:
        arr = f"numpy.array([{', '.join(repr(float(v)) for v in values)}])"
        setup.append(f"{up}_{dname.upper()} = {arr}" + ("" if width == 1 else ".reshape(-1, 3)"))
    return tuple(setup), names


def py_term_gradient(t: TermLoop, call: str) -> tuple[str, ...]:
    """Lines adding a term's member gradients, computed by `call`, into g (rows by body)."""
    names = _index_names(t)
    if len(names) == 1:
        return (f"numpy.add.at(g, {names[0]}, {call})",)
    blocks = [f"g{i}" for i in t.loop.kind.kind.indices]
    return (
        f"{', '.join(blocks)} = {call}",
        *(f"numpy.add.at(g, {name}, {b})" for name, b in zip(names, blocks)),
    )


def py_quad(t: TermLoop, call: str, n: int) -> tuple[str, ...]:
    """Lines adding one quadratic term's members, coefficients from `call`, into K (`kq`) and
    b, c (`kb`), component-major: local coordinate r at u n + body."""
    index = _index_names(t)

    def at(r: int) -> str:
        return f"{r % 3 * n} + {index[r // 3]}"

    lines = [f"coef = {call}"]
    for slot, r, c in t.quadratic:
        value = f"numpy.broadcast_to(coef[..., {slot}], {index[0]}.shape)"
        if r < 0:
            lines.append(f"kb[-1] += float(numpy.sum({value}))")
        elif c < 0:
            lines.append(f"numpy.add.at(kb, {at(r)}, {value})")
        else:
            lines.append(f"numpy.add.at(kq, ({at(r)}, {at(c)}), {value})")
            if r != c:
                lines.append(f"numpy.add.at(kq, ({at(c)}, {at(r)}), {value})")
    return tuple(lines)


def py_inertia_setup(module: Module) -> tuple[str, ...]:
    """Module-level arrays of M's per-body data (and the body index its kernels read).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("rope"))
        >>> py_inertia_setup(m)[0]
        'INDEX = numpy.arange(1.0, NBODIES + 1.0)'
    """
    per_body = any(k.name == "inertia_body" for k in module.kernels)
    lines = []
    if module.inertia_data or module.kind is ModuleKind.SPHERE and per_body:
        lines.append("INDEX = numpy.arange(1.0, NBODIES + 1.0)")
    for name, values in module.inertia_data:
        lits = ", ".join(repr(float(v)) for v in values)
        lines.append(f"INERTIA_{name.upper()} = numpy.array([{lits}])")
    return tuple(lines)


def py_data_setup(module: Module) -> tuple[str, ...]:
    """Module-level arrays of the per-body data the terms read (one per datum, by body).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> py_data_setup(lower_system(builtin("molecular")))
        ()
    """
    lines = []
    for name, width, values in module.body_data:
        lits = ", ".join(repr(float(v)) for v in values)
        shape = "" if width == 1 else f".reshape({module.n}, {width})"
        lines.append(f"DATA_{name} = numpy.array([{lits}]){shape}")
    return tuple(lines)


def py_table_names(module: Module) -> tuple[str, ...]:
    """The local names of the terms' member tables, in the order of their calls.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("dipoles"))
        >>> py_table_names(m)
        ('tab0',)
    """
    return tuple(_table_name(t.index) for t in module.terms if t.table)


def py_docstring(module: Module) -> tuple[str, str]:
    """(title, state paragraph) of the NumPy module's docstring.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> py_docstring(m)[1]
        'States are arrays q, w of shape (2, 3).'
    """
    n, name = module.n, module.name
    facts = dict(module.facts)
    if module.kind is ModuleKind.SPHERE:
        driven = (
            " Driven system (forces, inputs or time t): potential, gradient, energy and rhs take "
            "the time and the inputs as a last argument tu (tu[0] = t, tu[1 + k] = input k of "
            "INPUTS; default TU_DEFAULTS: t = 0 and the inputs' defaults); integrate() and "
            "step() hold the inputs over each step (zero-order hold)."
        )
        return (
            f'Equations of motion and integrators for the system "{name}" on (S^2)^{n} (NumPy).',
            f"States are arrays q, w of shape ({n}, 3).{driven if module.drive else ''}",
        )
    title = (
        f'The classical spherical-angle form of the system "{facts.get("system", name)}" '
        f"({n} bodies), NumPy."
    )
    state = (
        "Body i has the angles (theta_i, phi_i) and q_i = (sin theta_i cos phi_i, "
        "sin theta_i sin phi_i, cos theta_i); SymPy derived M(x) xdd = F(x, xd) from "
        f"L = 1/2 sum_ij M_ij qdot_i . qdot_j - V(q) ({facts.get('derivation', '')}). States "
        f"x = (theta_1, phi_1, ...) and xd are arrays of {2 * n}. Where sin theta_i = 0 "
        "phi_i is arbitrary and M(x) singular: to_angles returns ERR_POLE when sin theta_i < "
        "POLE_TOL, rhs returns ERR_SINGULAR when min |pivot| <= MIN_PIVOT_RATIO max |pivot|."
    )
    return title, state


def py_drive(drive: Drive | None) -> dict[str, Any]:
    """NumPy's entries of ``m.drive``: the functions' time-and-inputs parameter ``tu`` (its
    default the time 0 and the inputs' defaults) and how they pass it on, the forces' and the
    end-velocity terms' outputs, and the end velocity's Newton iteration (its limit, whether
    one solve is exact, the Jacobian's update). A closed module has no ``tu``.

    Example:
        >>> from s2gen.ir import Drive
        >>> d = py_drive(Drive(("tau",), (1.0,), True, True))
        >>> d["py_tu"], d["py_force"], d["py_limit"]
        (', tu=TU_DEFAULTS', 'F, Fw', 'newton_maxiter')
        >>> py_drive(None)["py_tu"]
        ''
    """
    if drive is None:
        return {"py_tu": "", "py_pass": "", "py_jacobian": ()}
    velocity = drive.velocity
    return {
        "py_tu": ", tu=TU_DEFAULTS",
        "py_pass": ", tu",
        "py_force": "F, Fw" if velocity else "F",
        "py_fvel": "c, jc" if velocity else "c",
        "py_limit": "newton_maxiter" if velocity else "1",
        "py_exact": "False" if velocity else "True",
        "py_jacobian": ("jm = jm - jc.reshape(3 * NBODIES, 3 * NBODIES)",) if velocity else (),
    }
