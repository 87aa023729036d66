"""The C99 printer: lowered kernels, loops, calls and declarations as C text.

Input: IR records (`Kernel`, `TermLoop`, `Call`, interface records). Output: strings and
tuples of lines for the templates. Symbols are mapped to argument slots by overriding the
printer's `_print_Symbol` (no string replacement): an array input `q` with symbols
(q_0, q_1, q_2) prints as `q[0]`, `q[1]`, `q[2]`; a system kernel's positions as `q[3*i + c]`.

Example:
    >>> import sympy as sp
    >>> x = sp.Symbol("x", real=True)
    >>> CPrinter({x: "q[0]"}).doprint(sp.sqrt(x) + sp.pi)
    'sqrt(q[0]) + 3.14159265358979323846'
"""

from __future__ import annotations

import math

import sympy as sp
from sympy.printing.c import C99CodePrinter

from s2gen.interface import Field, Function, Kind, Param
from s2gen.ir import Kernel, TermLoop
from s2gen.terms import Enumeration, Rule, TermKind

__all__ = [
    "EXACT_INTEGER",
    "CPrinter",
    "ExactIntegers",
    "LiteralError",
    "c_decl",
    "c_field_decl",
    "c_inline",
    "c_kernel",
    "c_loop",
    "c_quad_scatter",
    "c_string",
    "c_term_gradient",
    "c_term_row",
    "c_term_tables",
    "double_literal",
    "inline_names",
    "rows",
]


class LiteralError(ValueError):
    """A number of an expression cannot be a double (beyond its range, or complex)."""


#: Integers up to this magnitude are exact doubles, and so is the quotient p.0/q.0 of two of
#: them correctly rounded; beyond it a literal is printed as the correctly rounded double.
EXACT_INTEGER = 2**53


def c_string(text: str) -> str:
    """`text` as a C string literal (printable ASCII; quote and backslash escaped).

    Example:
        >>> print(c_string('say "hi" \\\\ bye'))
        "say \\"hi\\" \\\\ bye"
    """
    if not text.isascii() or not text.isprintable():
        raise ValueError(f"not printable ASCII: {text!r}")
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def double_literal(value: sp.Rational) -> str:
    """The shortest literal that reads back as the double nearest to the exact `value`
    (Python's int / int is correctly rounded); LiteralError beyond the range of a double.

    Example:
        >>> double_literal(sp.Integer(2)**64), double_literal(sp.Rational(1, 10**400))
        ('1.8446744073709552e+19', '0.0')
    """
    try:
        number = int(value.p) / int(value.q)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        shown = sp.Float(value, 4)
        raise LiteralError(
            f"the number {shown} (in an expression of the system or its derivatives) is "
            "beyond the range of a double (magnitude at most about 1.8e308); rescale the "
            "parameters or the expression"
        )
    return repr(number)


#: A term kernel's own position vectors (one-body and pair terms).
POSITIONS = ("q", "qi", "qj")


class ExactIntegers:
    """Printer mixin: an integer exact in a double prints as itself, a larger one as the
    correctly rounded double literal (C and NumPy alike)."""

    def _print_Integer(self, expr: sp.Integer) -> str:
        if abs(int(expr)) <= EXACT_INTEGER:
            return str(int(expr))
        return double_literal(expr)


class CPrinter(ExactIntegers, C99CodePrinter):
    """C99 printer with symbols mapped to argument slots; every number a C99 double literal.

    SymPy's C printer writes the POSIX macros M_PI, M_SQRT2, M_E ... (not in C99's math.h),
    integers beyond 64 bits as integer constants (truncated by the compiler) and sqrt(-1) as
    I (complex.h): here constants are literals with 21 significant digits, exact integers and
    rationals beyond 2**53 the correctly rounded double, and complex numbers an error.
    """

    def __init__(self, names: dict[sp.Symbol, str]) -> None:
        super().__init__({"math_macros": {}})
        self._names = names

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        name = self._names.get(expr)
        return name if name is not None else super()._print_Symbol(expr)

    def _print_NumberSymbol(self, expr: sp.Expr) -> str:
        return str(expr.evalf(21))

    _print_Pi = _print_Exp1 = _print_NumberSymbol
    _print_EulerGamma = _print_Catalan = _print_GoldenRatio = _print_NumberSymbol

    def _print_Rational(self, expr: sp.Rational) -> str:
        if abs(int(expr.p)) <= EXACT_INTEGER and int(expr.q) <= EXACT_INTEGER:
            return f"{int(expr.p)}.0/{int(expr.q)}.0"
        return double_literal(expr)

    def _print_Float(self, expr: sp.Float) -> str:
        number = float(expr)
        if not math.isfinite(number):
            raise LiteralError(
                f"the number {sp.Float(expr, 4)} is beyond the range of a double (magnitude at "
                "most about 1.8e308)"
            )
        if number == 0.0:
            return "0.0"  # also a nonzero float below the smallest double (gcc: an error)
        return str(super()._print_Float(expr))

    def _print_Pow(self, expr: sp.Pow) -> str:
        """x**(1/3) as pow(x, 1.0/3.0), not SymPy's cbrt: the expression means the principal
        root (not real for x < 0, as the spec's checks and the NumPy module have it: NaN), and
        cbrt's real cube root would make the C alone return a number there."""
        if expr.exp == sp.Rational(1, 3):
            return f"pow({self._print(expr.base)}, {self._print(expr.exp)})"
        return str(super()._print_Pow(expr))

    def _print_ImaginaryUnit(self, expr: sp.Expr) -> str:
        raise LiteralError("a complex number (I) cannot be printed as C double arithmetic")

    def _print_Infinity(self, expr: sp.Expr) -> str:
        raise LiteralError("an infinite number cannot be printed as a C literal")

    _print_NegativeInfinity = _print_ComplexInfinity = _print_NaN = _print_Infinity


def slot_names(kernel: Kernel) -> dict[sp.Symbol, str]:
    """C slots of a kernel's input symbols: scalars by name, arrays indexed (flat)."""
    names: dict[sp.Symbol, str] = {}
    for arg in kernel.inputs:
        if arg.scalar:
            names[arg.symbols[0]] = arg.name
        else:
            names.update({s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)})
    return names


def c_kernel(kernel: Kernel, restrict: str) -> tuple[str, tuple[str, ...]]:
    """(parameter list, body lines) of a kernel; `restrict` is the module's restrict macro."""
    pr = CPrinter(slot_names(kernel))
    params = [
        f"const double {a.name}" if a.scalar else f"const double *{restrict} {a.name}"
        for a in kernel.inputs
    ] + [f"double *{restrict} {o.name}" for o in kernel.outputs]
    used: set[sp.Basic] = set()
    for a in kernel.assignments:
        used |= a.expr.free_symbols
    lines = [f"(void){a.name};" for a in kernel.inputs if not set(a.symbols) & used]
    for a in kernel.assignments:
        rhs = pr.doprint(a.expr)
        if a.temp is not None:
            lines.append(f"const double {a.temp} = {rhs};")
        else:
            assert a.output is not None
            lines.append(f"{a.output[0]}[{a.output[1]}] = {rhs};")
    return ", ".join(params), tuple(lines)


def inline_names(kernel: Kernel, scalars: tuple[str, ...] = POSITIONS) -> dict[sp.Symbol, str]:
    """The C names of `kernel`'s inputs when it is written inline (see `c_inline`).

    Example:
        >>> from s2gen.ir import Argument
        >>> a = sp.symbols("qi_0:3", real=True)
        >>> b = sp.Symbol("b", real=True)
        >>> k = Kernel("k", "", (Argument("qi", a), Argument("b_c", (b,), scalar=True)), (), (), 0, 0)
        >>> list(inline_names(k).values())
        ['qi0', 'qi1', 'qi2', 'b_c']
    """
    names: dict[sp.Symbol, str] = {}
    for arg in kernel.inputs:
        if arg.shared:
            names.update({s: f"c{k}" for k, s in enumerate(arg.symbols)})
        elif arg.name in scalars:
            names.update({s: f"{arg.name}{k}" for k, s in enumerate(arg.symbols)})
        elif arg.scalar:
            names[arg.symbols[0]] = arg.name
        else:
            names.update({s: f"{arg.name}[{k}]" for k, s in enumerate(arg.symbols)})
    return names


def c_inline(
    kernel: Kernel, scalars: tuple[str, ...] = POSITIONS
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """A kernel's body written inline, for a loop that keeps its operands in scalars: every
    array input `x` named in `scalars` is read from the scalars x0, x1, x2, a shared array `cc`
    from c0, c1, ... (which the loop loads once), other arrays by index; every output slot
    `y[k]` is the scalar yk. Returns (the shared slots it reads, as `cK` names; the lines).

    Example:
        >>> import sympy as sp
        >>> from s2gen.ir import Argument, Output
        >>> from s2gen.passes import lower
        >>> from s2gen.ir import KernelDef
        >>> a = sp.symbols("qi_0:3", real=True)
        >>> k = lower(KernelDef("k", "", (Argument("qi", a),), (Output("g", (2 * a[0],)),)))
        >>> c_inline(k)[1]
        ('const double g0 = 2*qi0;',)
    """
    names = inline_names(kernel, scalars)
    shared: list[str] = []
    used: set[sp.Basic] = set()
    for a in kernel.assignments:
        used |= a.expr.free_symbols
    for arg in kernel.inputs:
        if arg.shared:
            shared += [names[s] for s in arg.symbols if s in used]
    pr = CPrinter(names)
    lines = []
    for a in kernel.assignments:
        rhs = pr.doprint(a.expr)
        target = a.temp if a.temp is not None else f"{a.output[0]}{a.output[1]}"  # type: ignore[index]
        lines.append(f"const double {target} = {rhs};")
    return tuple(shared), tuple(lines)


def rows(values: list[str], per_row: int = 6) -> tuple[str, ...]:
    """Literals grouped into rows of a C initializer."""
    return tuple(", ".join(values[k : k + per_row]) for k in range(0, len(values), per_row))


def c_term_tables(prefix: str, t: TermLoop) -> list[tuple[str, str, int, tuple[str, ...]]]:
    """The static tables of one term loop: member body indices (listed selections) and data."""
    pre = f"{prefix}_t{t.index}"
    tables: list[tuple[str, str, int, tuple[str, ...]]] = []
    if t.loop.kind.listed:
        for r, index in enumerate(t.loop.kind.kind.indices):
            idx = [str(mem[r]) for mem in t.loop.members]
            tables.append(("int", f"{pre}_{index}", t.loop.count, rows(idx, 16)))
    for dname, _, values in t.data:
        lits = [repr(float(v)) for v in values]
        tables.append(("double", f"{pre}_{dname}", len(values), rows(lits)))
    return tables


def _shifted(shift: int, rule: Rule, n: int) -> str:
    """The body m + shift of a SHIFTED member m (mod n when the rule wraps)."""
    if shift == 0:
        return "m"
    return f"(m + {shift}) % {n}" if rule.wrap else f"m + {shift}"


def c_loop(prefix: str, t: TermLoop, n: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(opening lines, closing lines) of a term's member loop; inside, m is the member and
    i (and j) its bodies.

    Example:
        >>> from s2gen.ir import Loop, LoopKind
        >>> t = TermLoop(0, Loop(LoopKind.CHAIN, 3), (), "t0_value", "t0_gradient")
        >>> c_loop("s", t, 4)[0][-1].strip()
        'const long i = m, j = m + 1;'
    """
    pre, count = f"{prefix}_t{t.index}", t.loop.count
    rule, indices = t.loop.kind.rule, t.loop.kind.kind.indices
    triangle = rule.enumeration is Enumeration.TRIANGLE
    decl = "long m, pi = 0, pj = 1;" if triangle else "long m;"
    head = ["    {", f"        {decl}", f"        for (m = 0; m < {count}; ++m) {{"]
    if rule.enumeration is Enumeration.SHIFTED:
        bodies = ", ".join(f"{i} = {_shifted(s, rule, n)}" for i, s in zip(indices, rule.shifts))
        head.append(f"            const long {bodies};")
    elif rule.enumeration is Enumeration.TABLE:
        bodies = ", ".join(f"{i} = {pre}_{i}[m]" for i in indices)
        head.append(f"            const long {bodies};")
    elif triangle:
        head += [
            "            /* every pair i < j, in row order; m counts pairs */",
            "            const long i = pi, j = pj;",
            f"            if (++pj == {n}) {{",
            "                ++pi;",
            "                pj = pi + 1;",
            "            }",
        ]
    else:
        raise ValueError(f"{t.loop.kind} is not a member loop")
    return tuple(head), ("        }", "    }")


def c_term_gradient(kind: TermKind) -> tuple[str, tuple[str, ...]]:
    """(declaration of the member's gradient blocks, lines adding them into g) of a term.

    Example:
        >>> c_term_gradient(TermKind.BODY)
        ('double gb[3];', ('g[3 * i] += gb[0];', 'g[3 * i + 1] += gb[1];', 'g[3 * i + 2] += gb[2];'))
    """
    names = ["gb"] if kind.arity == 1 else [f"g{i}" for i in kind.indices]
    declare = f"double {', '.join(f'{g}[3]' for g in names)};"
    add = tuple(
        f"g[3 * {i}{s}] += {g}[{c}];"
        for g, i in zip(names, kind.indices)
        for c, s in enumerate(("", " + 1", " + 2"))
    )
    return declare, add


def c_term_row(t: TermLoop, call: str) -> tuple[str, ...]:
    """Lines pointing `tab` at member m's row of the term's table (in the context, or computed
    into a local row by `call` when the context holds none)."""
    k = t.index
    return (
        f"double row[{t.table}];",
        f"const double *tab = cx->t{k} ? cx->t{k} + {t.table} * m : row;",
        f"if (!cx->t{k}) {{",
        f"    {call};",
        "}",
    )


def c_quad_scatter(t: TermLoop, n: int) -> tuple[str, ...]:
    """Lines adding member m's coefficients (`row`) into K (`kq`) and b, c (`kb`): local
    coordinate r is component r % 3 of the member's body r // 3, at u n + body in K."""
    indices, n3 = t.loop.kind.kind.indices, 3 * n

    def at(r: int) -> str:
        return f"{r % 3 * n} + {indices[r // 3]}"

    lines = []
    for slot, r, c in t.quadratic:
        if r < 0:
            lines.append(f"kb[{n3}] += row[{slot}];")
        elif c < 0:
            lines.append(f"kb[{at(r)}] += row[{slot}];")
        else:
            lines.append(f"kq[({at(r)}) * {n3} + {at(c)}] += row[{slot}];")
            if r != c:
                lines.append(f"kq[({at(c)}) * {n3} + {at(r)}] += row[{slot}];")
    return tuple(lines)


_C_TYPES = {
    Kind.DOUBLE: "double {}",
    Kind.INT: "int {}",
    Kind.LONG: "long {}",
    Kind.CONST_ARRAY: "const double *{}",
    Kind.ARRAY: "double *{}",
    Kind.LONG_ARRAY: "long *{}",
    Kind.INT_OUT: "int *{}",
    Kind.OPTIONS: "const {prefix}_options *{}",
    Kind.OPTIONS_OUT: "{prefix}_options *{}",
    Kind.STATS: "{prefix}_stats *{}",
    Kind.STEPPER: "{prefix}_stepper *{}",
    Kind.VECTOR3: "double {}[3]",
    Kind.FEEDBACK: "{prefix}_feedback {}",
    Kind.POINTER: "void *{}",
}


def _typed(kind: Kind, name: str, prefix: str) -> str:
    return _C_TYPES[kind].replace("{prefix}", prefix).format(name)


def c_decl(prefix: str, f: Function, width: int = 100) -> str:
    """The C prototype of a public function (no semicolon), wrapped at `width` columns."""
    ret = "void" if f.returns is Kind.VOID else _typed(f.returns, "", prefix).strip()
    line = f"{ret} {prefix}_{f.name}("
    lines: list[str] = []
    for k, p in enumerate(f.params):
        piece = _typed(p.kind, p.name, prefix) + (", " if k + 1 < len(f.params) else ")")
        if len(line) + len(piece.rstrip()) > width:
            lines.append(line.rstrip())
            line = "        "
        line += piece
    return "\n".join([*lines, line if f.params else line + "void)"])


def c_field_decl(prefix: str, f: Field) -> str:
    """A struct field's C declaration (no semicolon)."""
    return _typed(f.kind, f.name, prefix)


def nullable_note(params: tuple[Param, ...]) -> str:
    """'x and y may be NULL' for a function's nullable parameters ('' if none)."""
    names = [p.name for p in params if p.nullable]
    if not names:
        return ""
    return f"{' and '.join(names) if len(names) < 3 else ', '.join(names)} may be NULL."
