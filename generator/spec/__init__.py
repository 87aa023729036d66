"""The front doors: TOML spec files and the Python API, with a safe expression parser.

Input: a TOML file (`load_spec`), TOML text (`load_spec_text`) or Python values
(`define_system`); expressions are strings in a small, whitelisted language (`parse_expression`)
or ready-made SymPy objects.
Output: a validated `System` (built by `System.create`, which does the semantic checks), or a
`SpecError` naming the file, the key (table and key, list indices 1-based as for bodies and
the entries of M) and the offending item.

Expression language (parsed with `ast`, walked with an explicit whitelist; never evaluated):
numbers, unary + and -, binary + - * / **, parentheses, declared parameters, `pi`, the body
vectors `q1`..`qn` and unit axes `e1`, `e2`, `e3` (3-vectors), literal subscripts `v[0]`..`v[2]`
of a vector, and the calls `dot(a, b)`, `cross(a, b)`, `norm(a)`, `sqrt`, `exp`, `log`, `sin`,
`cos`, `tan`, `Abs`. A multi-line string may break anywhere, as inside parentheses. Lines
and columns in messages count from 1 within the expression string.

Structured potentials: besides (or instead of) the general `V`, the [potential] table may hold
one-body and pair terms, each a sum of one expression over its members::

    [potential]
    V = "..."                # optional general part when terms are given

    [[potential.body]]       # a one-body term (any number of them)
    V = "-m*g*l*dot(e3, q)"  # in the body's own vector q
    bodies = "all"           # or a list of 1-based body indices, e.g. [1, 3]; default "all"
    [potential.body.data]    # optional per-body data: one value per body of the selection
    l = [0.1, 0.2]

    [[potential.pair]]       # a pair term, in the pair's vectors qi and qj
    V = "k/2*(norm(r + l/2*qj - l/2*qi) - norm(r))**2"
    pairs = [[1, 2], [2, 3], [3, 4], [4, 1]]   # or "chain" (i, i+1) or "all" (every i < j)
    [potential.pair.data]    # per-pair data (not with pairs = "all": use a parameter there)
    k = [10, 20, 30, 40]
    r = [[0.1, 0, 0], [0, -0.1, 0], [-0.1, 0, 0], [0, 0.1, 0]]

    [[potential.pair]]       # over all pairs, optionally only those closer than a cutoff
    V = "4*eps*((sigma**2/dot(qi - qj, qi - qj))**6 - (sigma**2/dot(qi - qj, qi - qj))**3)"
    pairs = "all"
    cutoff = 0.1             # chord distance |qi - qj|; cell lists make the cost O(n)

A term expression sees its own vectors (`q`, or `qi` and `qj`), its data, the parameters and
everything above except the global `q1..qn`. A datum is a list with one entry per member, all
numbers (a scalar, symbol `name`) or all 3-vectors (usable wherever a vector is: `dot(r, qi)`,
`r[1]`; symbols `name_0..name_2`); entries are numbers or expression strings in numbers and
parameters, evaluated to floats. Data names must not clash with parameters, reserved names or
`q`, `qi`, `qj`. Terms are labelled "[[potential.body]] #k" / "[[potential.pair]] #k" (k from
1, in file order); errors name them, e.g. ``spec.toml: [[potential.pair]] #2 data.k: ...``.
The Python API takes the same tables as dicts: ``define_system(..., body_terms=[{"V": ...,
"bodies": ..., "data": {...}}], pair_terms=[{"V": ..., "pairs": ..., "data": {...}}])``.

Example:
    >>> s = define_system(name="pendulum", bodies=1, parameters={"m": 1.0, "g": 9.81},
    ...                   diagonal=["m"], potential="-m*g*dot(e3, q1)")
    >>> s.potential
    -g*m*q1_2
"""

from __future__ import annotations

import ast
import keyword
import math
import numbers
import operator
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
import sympy as sp

from s2gen.symbols import local_vector, q_vector
from s2gen.system import RunSettings, SpecError, System, Term, TermData

__all__ = [
    "METHODS",
    "RESERVED_NAMES",
    "define_system",
    "load_spec",
    "load_spec_text",
    "parse_expression",
]

API_ORIGIN = "<python api>"
METHODS = ("vi", "rk45", "rk2", "rk2-proj", "rk4")

_SCALAR_FUNCTIONS: dict[str, Callable[[sp.Expr], sp.Expr]] = {
    "sqrt": sp.sqrt,
    "exp": sp.exp,
    "log": sp.log,
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "Abs": sp.Abs,
}
_VECTOR_FUNCTIONS = {"dot": 2, "cross": 2, "norm": 1}
_AXES = {f"e{k + 1}": sp.ImmutableMatrix([int(k == c) for c in range(3)]) for k in range(3)}
#: Names the expression language gives a meaning; parameters may not use them.
RESERVED_NAMES = frozenset({"pi", *_SCALAR_FUNCTIONS, *_VECTOR_FUNCTIONS, *_AXES})
_Q_NAME = re.compile(r"q([0-9]+)")
_Q_RESERVED = re.compile(r"q[0-9]+(_[0-9]+)?")
#: The own vectors of term expressions: q (one-body terms), qi and qj (pair terms).
_ROLES = ("q", "qi", "qj")
_MAX_LENGTH = 100_000
_MAX_DIGITS = 1000
_NON_FINITE = (sp.zoo, sp.oo, sp.S.NegativeInfinity, sp.nan)

_OPERATORS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_LEFT_ASSOCIATIVE = (ast.Add, ast.Sub, ast.Mult, ast.Div)
_ARITHMETIC: dict[str, Callable[[Any, Any], Any]] = {
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "**": operator.pow,
}
_BAD_OPERATORS = {
    ast.FloorDiv: "//",
    ast.Mod: "%",
    ast.MatMult: "@",
    ast.BitXor: "^",
    ast.BitAnd: "&",
    ast.BitOr: "|",
    ast.LShift: "<<",
    ast.RShift: ">>",
}
_NODE_NAMES = {
    ast.Attribute: "attribute access",
    ast.Lambda: "lambda",
    ast.ListComp: "list comprehension",
    ast.SetComp: "set comprehension",
    ast.DictComp: "dict comprehension",
    ast.GeneratorExp: "generator expression",
    ast.Compare: "comparison",
    ast.BoolOp: "boolean operator",
    ast.IfExp: "conditional expression",
    ast.List: "list",
    ast.Tuple: "tuple",
    ast.Dict: "dict",
    ast.Set: "set",
    ast.JoinedStr: "f-string",
    ast.NamedExpr: "assignment expression",
    ast.Starred: "starred expression",
    ast.Slice: "slice",
}

#: A parsed value: a scalar SymPy expression or a 3x1 vector.
Value: TypeAlias = "sp.Expr | sp.ImmutableMatrix"


# ====================================================================== expression parser
@dataclass(frozen=True)
class _Names:
    """The name table of one parse: what each name means, and why a missing one is missing.

    `fixed` holds pi, the parameters, the axes and a term's local names; the global body
    vectors q1..q{bodies} are resolved on demand (a long chain need not build n matrices).
    """

    fixed: Mapping[str, Value]
    bodies: int  # q1..q{bodies} are the global body vectors (0 inside a term or without vectors)
    n: int  # the number of bodies, for messages
    roles: tuple[str, ...]  # a term's own vectors (q, or qi and qj); empty outside a term
    term: bool
    allow_vectors: bool

    def lookup(self, name: str) -> Value | None:
        """The value of `name`, or None when it means nothing here."""
        if name in self.fixed:
            return self.fixed[name]
        match = _Q_NAME.fullmatch(name)
        if match and not name.startswith("q0") and 1 <= int(match.group(1)) <= self.bodies:
            return sp.ImmutableMatrix(q_vector(int(match.group(1))))
        return None

    def explain(self, name: str) -> str:
        """Why `name` means nothing here (the message of the error)."""
        global_q = _Q_NAME.fullmatch(name) is not None
        if not self.allow_vectors and (global_q or name in _AXES or name in _ROLES):
            return f"{name!r} is not allowed here (only numbers and parameters)"
        own = " and ".join(self.roles)
        if global_q and self.term:
            return (
                f"the global position {name!r} is not allowed in a term expression "
                f"(a term sees only its own vectors, here {own})"
            )
        if global_q:
            return f"no body {name!r}: the bodies are q1..q{self.n}"
        if name in _ROLES and self.term:
            return f"unknown name {name!r} (this term's own vectors are {own})"
        if name in _ROLES:
            return (
                f"unknown name {name!r} (q, qi and qj exist only in term expressions: "
                "[[potential.body]] has q, [[potential.pair]] has qi and qj)"
            )
        return f"unknown name {name!r}"


@dataclass(frozen=True)
class _Context:
    """What a parse may see, plus what it needs to point at the offending token."""

    body: str  # the text given to ast.parse
    where: str
    names: _Names
    line_shift: int  # lines and first-line columns of `body` -> of the user's text
    col_shift: int

    def fail(self, node: ast.AST | None, message: str) -> SpecError:
        """A SpecError for `message` located at `node` (or without position)."""
        if node is None or not hasattr(node, "lineno"):
            return SpecError(f"{self.where}: {message}")
        line, byte_col = node.lineno, node.col_offset  # type: ignore[attr-defined]
        source = self.lines[min(line, len(self.lines)) - 1].encode()
        col = len(source[:byte_col].decode(errors="ignore"))
        return SpecError(f"{self.where}: {message} at {self.position(line, col)}")

    @property
    def lines(self) -> list[str]:
        """`body` split the way the tokenizer counts lines."""
        return re.split(r"\r\n|\r|\n", self.body)

    def position(self, line: int, col: int) -> str:
        """'column C' or 'line L, column C' in the original text (1-based, characters)."""
        if line == 1:
            col += self.col_shift
        line += self.line_shift
        return f"column {col + 1}" if line == 1 else f"line {line}, column {col + 1}"

    def token(self, node: ast.AST) -> str:
        """The source text of `node`, shortened for messages."""
        segment = ast.get_source_segment(self.body, node) or type(node).__name__
        return segment if len(segment) <= 40 else segment[:37] + "..."

    def operator(self, node: ast.BinOp) -> ast.AST:
        """A stand-in node located at the operator of `node` (ast does not record it)."""
        line, byte_col = node.left.end_lineno or 1, node.left.end_col_offset or 0
        rest = self.lines[line - 1].encode()[byte_col:].decode(errors="ignore")
        skip = len(rest) - len(rest.lstrip(" \t)"))
        marker = ast.Constant(value=None)
        marker.lineno = line
        marker.col_offset = byte_col + len(rest[:skip].encode())
        return marker


def parse_expression(
    text: str,
    *,
    n: int,
    parameters: Sequence[str],
    where: str,
    allow_vectors: bool = True,
    local: Mapping[str, int] | None = None,
) -> sp.Expr:
    """Parse a scalar expression of the spec language into SymPy, safely (raises SpecError).

    With ``allow_vectors=False`` only numbers, parameters, pi and scalar functions may appear
    (used for inertia entries and initial values). `local` makes it a term expression: it maps
    the term's own names (its vectors q, or qi and qj, and its data) to their widths, 3 for a
    vector (symbols name_0..name_2, see `local_vector`) or 1 for a scalar (the symbol name);
    the global q1..qn are then refused.

    Example:
        >>> parse_expression("m*g*dot(e3, q1) + q2[0]/2", n=2, parameters=["m", "g"],
        ...                  where="spec.toml: [potential] V")
        g*m*q1_2 + q2_0/2
        >>> parse_expression("k*(dot(r, qj) - 1) + qi[2]", n=2, parameters=["k"],
        ...                  where="spec.toml: [[potential.pair]] #1 V",
        ...                  local={"qi": 3, "qj": 3, "r": 3})
        k*(qj_0*r_0 + qj_1*r_1 + qj_2*r_2 - 1) + qi_2
    """
    bad = [p for p in parameters if p in RESERVED_NAMES or _Q_RESERVED.fullmatch(p)]
    if bad:
        raise SpecError(f"{where}: parameter name {bad[0]!r} is reserved")
    names = _name_table(n, parameters, allow_vectors, local, where)
    ctx, tree = _parse(text, where, names)
    try:
        result = _eval(ctx, tree.body)
    except RecursionError:
        raise SpecError(f"{where}: expression nested too deeply") from None
    if isinstance(result, sp.MatrixBase):
        raise ctx.fail(
            tree.body,
            f"the expression {ctx.token(tree.body)!r} is a vector, but a scalar is required "
            "(use dot(a, b) or a component such as q1[2])",
        )
    return result


def _name_table(
    n: int,
    parameters: Sequence[str],
    allow_vectors: bool,
    local: Mapping[str, int] | None,
    where: str,
) -> _Names:
    """The names a parse may use: pi, parameters, axes, then q1..qn or a term's local names."""
    fixed: dict[str, Value] = {"pi": sp.pi}
    fixed.update({p: sp.Symbol(p, real=True) for p in parameters})
    if allow_vectors:
        fixed.update(_AXES)
    for name, width in (local or {}).items():
        if name in fixed or name in RESERVED_NAMES or _Q_RESERVED.fullmatch(name):
            what = "a parameter" if name in parameters else "reserved"
            raise SpecError(f"{where}: local name {name!r} clashes with {what} name {name!r}")
        if width not in (1, 3):
            raise SpecError(f"{where}: local name {name!r} has width {width}, not 1 or 3")
        if width == 1:
            fixed[name] = sp.Symbol(name, real=True)
        elif allow_vectors:
            fixed[name] = sp.ImmutableMatrix(local_vector(name))
    roles = tuple(r for r in _ROLES if local and local.get(r) == 3)
    bodies = n if allow_vectors and local is None else 0
    return _Names(fixed, bodies, n, roles, local is not None, allow_vectors)


def _parse(text: str, where: str, names: _Names) -> tuple[_Context, ast.Expression]:
    """Parse `text` (leading whitespace dropped: ast would call it an indent) into a tree.

    A multi-line text that is not valid as written is retried inside parentheses, so long
    TOML strings may break lines anywhere, as inside parentheses.
    """
    if not isinstance(text, str):
        raise SpecError(f"{where}: expected an expression string, got {text!r}")
    if len(text) > _MAX_LENGTH:
        raise SpecError(f"{where}: expression longer than {_MAX_LENGTH} characters")
    body = text.lstrip()
    if not body.strip():
        raise SpecError(f"{where}: empty expression")
    skipped = text[: len(text) - len(body)]
    ctx = _Context(
        body=body,
        where=where,
        names=names,
        line_shift=skipped.count("\n"),
        col_shift=len(skipped) - (skipped.rfind("\n") + 1),
    )
    try:
        return ctx, _ast_parse(ctx)
    except SyntaxError as exc:
        error = exc
    if "\n" in body.strip():
        wrapped = replace(ctx, body=f"({body}\n)", col_shift=ctx.col_shift - 1)
        try:
            return wrapped, _ast_parse(wrapped)
        except SyntaxError as exc:
            line, offset = exc.lineno or 1, exc.offset or 1
            if (line, offset) > (1, 1) and line <= body.rstrip().count("\n") + 1:
                ctx, error = wrapped, exc  # located inside the user's text: more precise
    at = ctx.position(error.lineno or 1, (error.offset or 1) - 1)
    raise SpecError(f"{where}: syntax error ({error.msg}) at {at}")


def _ast_parse(ctx: _Context) -> ast.Expression:
    try:
        return ast.parse(ctx.body, mode="eval")
    except (ValueError, RecursionError, MemoryError) as exc:
        raise SpecError(f"{ctx.where}: cannot parse the expression ({exc})") from None


def _eval(ctx: _Context, node: ast.AST) -> Value:
    handler = _HANDLERS.get(type(node))
    if handler is None:
        what = _NODE_NAMES.get(type(node), f"{type(node).__name__} expression")
        raise ctx.fail(node, f"{what} {ctx.token(node)!r} is not allowed")
    return _finite(ctx, node, handler(ctx, node))


def _finite(ctx: _Context, node: ast.AST, value: Value) -> Value:
    entries = value if isinstance(value, sp.MatrixBase) else [value]
    if any(e.has(*_NON_FINITE) for e in entries):
        raise ctx.fail(node, f"{ctx.token(node)!r} is not finite (division by zero?)")
    return value


def _constant(ctx: _Context, node: ast.Constant) -> Value:
    value = node.value
    if isinstance(value, bool):
        raise ctx.fail(node, f"boolean {value!r} is not allowed")
    if isinstance(value, int):
        return sp.Integer(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ctx.fail(node, f"number {ctx.token(node)!r} is not finite")
        return sp.Float(value)
    kind = "string" if isinstance(value, str) else f"constant of type {type(value).__name__}"
    if isinstance(value, complex):
        kind = "complex number"
    raise ctx.fail(node, f"{kind} {ctx.token(node)!r} is not allowed")


def _name(ctx: _Context, node: ast.Name) -> Value:
    name = node.id
    value = ctx.names.lookup(name)
    if value is not None:
        return value
    if name in _SCALAR_FUNCTIONS or name in _VECTOR_FUNCTIONS:
        raise ctx.fail(node, f"function {name!r} used without a call, e.g. {name}(...)")
    raise ctx.fail(node, ctx.names.explain(name))


def _unary(ctx: _Context, node: ast.UnaryOp) -> Value:
    operand = _eval(ctx, node.operand)
    if isinstance(node.op, ast.USub):
        return -operand
    if isinstance(node.op, ast.UAdd):
        return operand
    symbol = {ast.Not: "not", ast.Invert: "~"}.get(type(node.op), type(node.op).__name__)
    raise ctx.fail(node, f"operator {symbol!r} is not allowed")


def _binary(ctx: _Context, node: ast.BinOp) -> Value:
    """Binary operators. Left-associative chains (long sums) are walked without recursion,
    and runs of + and - are summed at once (adding term by term is quadratic in SymPy)."""
    chain: list[ast.BinOp] = []
    link: ast.AST = node
    while isinstance(link, ast.BinOp) and type(link.op) in _LEFT_ASSOCIATIVE:
        chain.append(link)
        link = link.left
    if not chain:
        return _single_binary(ctx, node)
    terms = [_eval(ctx, link)]
    for outer in reversed(chain):
        op = _OPERATORS[type(outer.op)]
        right = _eval(ctx, outer.right)
        if op in "+-":
            _check(ctx, outer, op, terms[0], right)
            terms.append(right if op == "+" else -right)
        else:
            terms = [_apply(ctx, outer, op, _total(terms), right)]
    return _total(terms)


def _total(terms: list[Value]) -> Value:
    if len(terms) == 1:
        return terms[0]
    if isinstance(terms[0], sp.MatrixBase):
        return sp.ImmutableMatrix([sp.Add(*(t[c] for t in terms)) for c in range(3)])
    return sp.Add(*terms)


def _single_binary(ctx: _Context, node: ast.BinOp) -> Value:
    op = _OPERATORS.get(type(node.op))
    if op is None:
        symbol = _BAD_OPERATORS.get(type(node.op), type(node.op).__name__)
        hint = " (use ** for powers)" if symbol == "^" else ""
        raise ctx.fail(ctx.operator(node), f"operator {symbol!r} is not allowed{hint}")
    left, right = _eval(ctx, node.left), _eval(ctx, node.right)
    return _apply(ctx, node, op, left, right)


def _apply(ctx: _Context, node: ast.BinOp, op: str, a: Value, b: Value) -> Value:
    _check(ctx, node, op, a, b)
    if op == "**":
        _check_power_size(ctx, node, a, b)
    return _ARITHMETIC[op](a, b)


def _check(ctx: _Context, node: ast.BinOp, op: str, a: Value, b: Value) -> None:
    """Raise if `a op b` mixes scalars and vectors wrongly or divides by zero."""
    va, vb = isinstance(a, sp.MatrixBase), isinstance(b, sp.MatrixBase)
    problem = None
    if op in "+-" and va != vb:
        problem = f"operator {op!r} cannot combine a scalar and a vector"
    elif op == "*" and va and vb:
        problem = "operator '*' cannot multiply two vectors (use dot or cross)"
    elif op == "/" and vb:
        problem = "operator '/' cannot divide by a vector"
    elif op == "/" and b.is_zero:
        problem = f"division by zero: {ctx.token(node.right)!r} is 0"
    elif op == "**" and (va or vb):
        problem = "operator '**' needs scalars (use dot(a, a) for a squared length)"
    if problem:
        raise ctx.fail(ctx.operator(node), problem)


def _check_power_size(ctx: _Context, node: ast.BinOp, base: sp.Expr, exponent: sp.Expr) -> None:
    """Refuse numeric powers whose exact value would have more than _MAX_DIGITS digits."""
    if not (isinstance(base, sp.Number) and isinstance(exponent, sp.Number)) or base == 0:
        return
    if isinstance(base, sp.Rational):
        size = abs(math.log10(abs(int(base.p)))) + math.log10(int(base.q))
    else:
        size = abs(math.log10(abs(float(base))))
    if abs(float(exponent)) * size > _MAX_DIGITS:
        raise ctx.fail(ctx.operator(node), f"power {ctx.token(node)!r} is too large")


def _call(ctx: _Context, node: ast.Call) -> Value:
    if not isinstance(node.func, ast.Name):
        what = _NODE_NAMES.get(type(node.func), "calling")
        raise ctx.fail(node.func, f"{what} {ctx.token(node.func)!r} is not allowed")
    name = node.func.id
    if name not in _SCALAR_FUNCTIONS and name not in _VECTOR_FUNCTIONS:
        known = ", ".join(sorted([*_SCALAR_FUNCTIONS, *_VECTOR_FUNCTIONS]))
        raise ctx.fail(node.func, f"{name!r} is not a known function (known: {known})")
    if name in _VECTOR_FUNCTIONS and not ctx.names.allow_vectors:
        raise ctx.fail(node.func, f"function {name!r} is not allowed here (no vectors)")
    if node.keywords:
        kw = node.keywords[0]
        raise ctx.fail(kw, f"keyword argument {ctx.token(kw)!r} is not allowed")
    arity = _VECTOR_FUNCTIONS.get(name, 1)
    if len(node.args) != arity:
        raise ctx.fail(node, f"{name}() takes {arity} argument(s), got {len(node.args)}")
    args = [_eval(ctx, arg) for arg in node.args]
    return _apply_function(ctx, node, name, args)


def _apply_function(ctx: _Context, node: ast.Call, name: str, args: list[Value]) -> Value:
    want_vector = name in _VECTOR_FUNCTIONS
    for k, (arg, arg_node) in enumerate(zip(args, node.args)):
        if isinstance(arg, sp.MatrixBase) != want_vector:
            kind = "a vector" if want_vector else "a scalar"
            token = ctx.token(arg_node)
            raise ctx.fail(arg_node, f"{name}() argument {k + 1} {token!r} must be {kind}")
    if name == "dot":
        return args[0].dot(args[1])
    if name == "cross":
        return sp.ImmutableMatrix(args[0].cross(args[1]))
    if name == "norm":
        return sp.sqrt(args[0].dot(args[0]))
    return _SCALAR_FUNCTIONS[name](args[0])


def _subscript(ctx: _Context, node: ast.Subscript) -> Value:
    value = _eval(ctx, node.value)
    if not isinstance(value, sp.MatrixBase):
        raise ctx.fail(node, f"cannot index the scalar {ctx.token(node.value)!r}")
    index = node.slice
    if not (isinstance(index, ast.Constant) and type(index.value) is int and 0 <= index.value <= 2):
        raise ctx.fail(index, f"index {ctx.token(index)!r} must be a literal 0, 1 or 2")
    return value[index.value]


_HANDLERS: dict[type, Callable[[_Context, Any], Value]] = {
    ast.Constant: _constant,
    ast.Name: _name,
    ast.UnaryOp: _unary,
    ast.BinOp: _binary,
    ast.Call: _call,
    ast.Subscript: _subscript,
}


# ====================================================================== the Python API
def define_system(
    *,
    name: str,
    bodies: int,
    parameters: Mapping[str, float],
    potential: str | float | sp.Expr | None = None,
    inertia: Sequence[Sequence[str | float | sp.Expr]] | sp.MatrixBase | None = None,
    diagonal: Sequence[str | float | sp.Expr] | None = None,
    initial_q: Sequence[Sequence[str | float | sp.Expr]] | np.ndarray | None = None,
    initial_omega: Sequence[Sequence[str | float | sp.Expr]] | np.ndarray | None = None,
    run: Mapping[str, Any] | RunSettings | None = None,
    origin: str = API_ORIGIN,
    body_terms: Sequence[Mapping[str, Any]] | None = None,
    pair_terms: Sequence[Mapping[str, Any]] | None = None,
) -> System:
    """Build a validated System from Python values (the same rules as a TOML spec).

    Expressions may be strings (parsed safely) or SymPy objects; give exactly one of
    `inertia` (n x n) and `diagonal` (n entries). `body_terms` and `pair_terms` are lists of
    dicts with the keys of a ``[[potential.body]]`` / ``[[potential.pair]]`` table (``V``,
    ``bodies`` / ``pairs`` with 1-based indices, ``data``); `potential` (the general part) may
    then be omitted. Raises SpecError naming `origin` and the key.

    Example:
        >>> s = define_system(name="pend", bodies=1, parameters={"m": 1.0, "l": 2.0},
        ...                   inertia=[["m*l**2"]], potential="-m*9.81*l*q1[2]",
        ...                   initial_q=[["sqrt(3)/2", 0, "1/2"]], initial_omega=[[0, 1, 0]])
        >>> s.inertia, s.q0.round(4).tolist()
        (Matrix([[l**2*m]]), [[0.866, 0.0, 0.5]])
        >>> s = define_system(name="ring", bodies=3, parameters={"m": 1.0, "k": 2.0},
        ...                   diagonal=["m"] * 3, body_terms=[{"V": "-m*q[2]"}],
        ...                   pair_terms=[{"V": "c*dot(qi, qj)", "pairs": [[1, 2], [2, 3]],
        ...                                "data": {"c": ["k", 3]}}])
        >>> [t.member_list(s.n) for t in s.terms], s.terms[1].data
        ([[(0,), (1,), (2,)], [(0, 1), (1, 2)]], (TermData(name='c', width=1, values=(2.0, 3.0)),))
    """
    params = _parameters(parameters, origin)
    n = _bodies(bodies, origin)
    names = list(params)
    matrix = _inertia(inertia, diagonal, n, names, origin)
    general = sp.Integer(0) if potential is None else _potential(potential, n, names, origin)
    terms = [
        *_terms(body_terms, _BODY, n, params, origin),
        *_terms(pair_terms, _PAIR, n, params, origin),
    ]
    if potential is None and not terms:
        raise SpecError(
            f"{origin}: [potential] V: missing (give V, or terms [[potential.body]] / "
            "[[potential.pair]])"
        )
    return System.create(
        name=name,
        n=n,
        parameters=params,
        inertia=matrix,
        potential=general,
        q0=_initial(initial_q, "q", n, params, origin),
        omega0=_initial(initial_omega, "omega", n, params, origin),
        run=_run_settings(run, origin),
        origin=origin,
        terms=terms,
    )


def _bodies(bodies: Any, origin: str) -> int:
    if isinstance(bodies, bool) or not isinstance(bodies, numbers.Integral) or bodies < 1:
        raise SpecError(f"{origin}: key 'bodies': expected a positive integer, got {bodies!r}")
    return int(bodies)


def _parameters(parameters: Any, origin: str) -> dict[str, float]:
    if not isinstance(parameters, Mapping):
        raise SpecError(f"{origin}: [parameters]: expected a table of name = number")
    values: dict[str, float] = {}
    for pname, value in parameters.items():
        where = f"{origin}: [parameters] {pname}"
        _check_parameter_name(pname, where)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise SpecError(f"{where}: expected a number, got {value!r}")
        if not math.isfinite(float(value)):
            raise SpecError(f"{where}: value {value!r} is not finite")
        values[pname] = float(value)
    return values


def _check_parameter_name(pname: Any, where: str) -> None:
    if not isinstance(pname, str) or not pname.isidentifier() or not pname.isascii():
        raise SpecError(f"{where}: {pname!r} is not an identifier")
    if keyword.iskeyword(pname):
        raise SpecError(f"{where}: {pname!r} is a reserved word")
    if pname in RESERVED_NAMES or _Q_RESERVED.fullmatch(pname):
        raise SpecError(
            f"{where}: {pname!r} is a reserved name (q1.., e1..e3, pi and the function "
            "names have fixed meanings)"
        )


def _scalar(value: Any, where: str, names: Sequence[str]) -> sp.Expr:
    """A number, an expression string in numbers and parameters, or a SymPy scalar."""
    if isinstance(value, bool):
        raise SpecError(f"{where}: expected a number or an expression string, got {value!r}")
    if isinstance(value, numbers.Integral):
        return sp.Integer(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, sp.Basic):
        if not math.isfinite(float(value)):
            raise SpecError(f"{where}: value {value!r} is not finite")
        return sp.Float(float(value))
    if isinstance(value, str):
        return parse_expression(value, n=0, parameters=names, where=where, allow_vectors=False)
    if isinstance(value, sp.Expr):
        return value
    raise SpecError(f"{where}: expected a number or an expression string, got {value!r}")


def _rows(value: Any, length: int, where: str, what: str) -> list[Any]:
    """`value` as a list of exactly `length` items (a precise error otherwise)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise SpecError(f"{where}: expected a list of {length} {what}, got {value!r}")
    if len(value) != length:
        raise SpecError(f"{where}: expected {length} {what}, got {len(value)}")
    return list(value)


def _inertia(
    inertia: Any, diagonal: Any, n: int, names: Sequence[str], origin: str
) -> sp.MatrixBase:
    where = f"{origin}: [inertia]"
    if (inertia is None) == (diagonal is None):
        given = "both" if inertia is not None else "neither"
        raise SpecError(f"{where}: give exactly one of 'M' and 'diagonal' (got {given})")
    if isinstance(inertia, sp.MatrixBase):
        return inertia
    if diagonal is not None:
        entries = _rows(diagonal, n, f"{where} diagonal", "entries (one per body)")
        return sp.diag(
            *[_scalar(v, f"{where} diagonal[{i + 1}]", names) for i, v in enumerate(entries)]
        )
    rows = _rows(inertia, n, f"{where} M", "rows")
    matrix = [_rows(row, n, f"{where} M[{r + 1}]", "entries") for r, row in enumerate(rows)]
    return sp.Matrix(
        [
            [_scalar(v, f"{where} M[{r + 1}][{c + 1}]", names) for c, v in enumerate(row)]
            for r, row in enumerate(matrix)
        ]
    )


def _potential(potential: Any, n: int, names: Sequence[str], origin: str) -> sp.Expr:
    where = f"{origin}: [potential] V"
    if isinstance(potential, str):
        return parse_expression(potential, n=n, parameters=names, where=where)
    if isinstance(potential, sp.MatrixBase):
        raise SpecError(f"{where}: the potential is a {potential.shape} matrix, not a scalar")
    if isinstance(potential, sp.Expr) or (
        isinstance(potential, numbers.Real) and not isinstance(potential, bool)
    ):
        return _scalar(potential, where, names)
    raise SpecError(f"{where}: expected an expression string or a SymPy scalar, got {potential!r}")


# ---------------------------------------------------------------------- structured potentials
@dataclass(frozen=True)
class _TermKind:
    """How one kind of term is written: its table, selection key, own vectors and selections."""

    kind: str  # "body" or "pair" (Term.kind)
    table: str  # the TOML array of tables, also the label prefix
    select_key: str
    roles: tuple[str, ...]
    selections: tuple[str, ...]
    options: str  # what the selection may be, for messages
    default: str | None  # the selection when the key is omitted (None: required)


_BODY = _TermKind(
    "body",
    "[[potential.body]]",
    "bodies",
    ("q",),
    ("all",),
    '"all" or a list of body indices',
    "all",
)
_PAIR = _TermKind(
    "pair",
    "[[potential.pair]]",
    "pairs",
    ("qi", "qj"),
    ("all", "chain"),
    '"all", "chain" or a list of pairs [i, j] of body indices',
    None,
)


def _terms(
    entries: Any, kind: _TermKind, n: int, params: Mapping[str, float], origin: str
) -> list[Term]:
    """The terms of one kind (None: none), labelled "[[potential.body]] #k" (k from 1)."""
    if entries is None:
        return []
    if isinstance(entries, (Mapping, str, bytes)) or not isinstance(entries, Sequence):
        raise SpecError(
            f"{origin}: {kind.table}: expected a list of term tables (in TOML an array of "
            f"tables, written {kind.table}), got {entries!r}"
        )
    return [_term(entry, kind, k + 1, n, params, origin) for k, entry in enumerate(entries)]


def _term(
    entry: Any, kind: _TermKind, k: int, n: int, params: Mapping[str, float], origin: str
) -> Term:
    """One term table: its key V, its selection and its per-member data."""
    label = f"{kind.table} #{k}"
    where = f"{origin}: {label}"
    if not isinstance(entry, Mapping):
        raise SpecError(f"{where}: expected a table (V, {kind.select_key}, data), got {entry!r}")
    allowed = ("V", kind.select_key, "data") + (("cutoff",) if kind.kind == "pair" else ())
    _check_keys(entry, allowed, where)
    for key in ("V", kind.select_key):
        if key not in entry and not (key == kind.select_key and kind.default):
            raise SpecError(f"{where}: missing required key {key!r}")
    for role in kind.roles:
        if role in params:
            raise SpecError(
                f"{where}: the parameter {role!r} clashes with the term's own vector {role} "
                "(rename the parameter)"
            )
    select, members = _selection(entry.get(kind.select_key, kind.default), kind, n, where)
    count = Term(kind.kind, sp.Integer(0), select, members).count(n)
    data = _term_data(entry.get("data"), kind, select, count, params, where)
    _check_symbols(kind, data, params, where)
    local = {**{role: 3 for role in kind.roles}, **{d.name: d.width for d in data}}
    expr = _term_expression(entry["V"], kind, n, local, params, f"{where} V")
    cutoff = None
    if entry.get("cutoff") is not None:
        cutoff = _number(entry["cutoff"], f"{where} cutoff", params)
        if not cutoff > 0.0 or select != "all":
            raise SpecError(
                f"{where} cutoff: must be a positive distance, on a term over all pairs "
                f"(got {entry['cutoff']!r} with pairs = {select!r})"
            )
    return Term(kind.kind, expr, select, members, data, label, cutoff)


def _selection(
    value: Any, kind: _TermKind, n: int, where: str
) -> tuple[str, tuple[tuple[int, ...], ...]]:
    """The selection key: a named selection, or a list of members (1-based -> 0-based)."""
    where = f"{where} {kind.select_key}"
    if isinstance(value, str) and value in kind.selections:
        return value, ()
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or not value:
        raise SpecError(f"{where}: expected {kind.options} 1..{n}, got {value!r}")
    return "list", tuple(
        _member(item, kind, n, f"{where}[{m + 1}]") for m, item in enumerate(value)
    )


def _member(item: Any, kind: _TermKind, n: int, where: str) -> tuple[int, ...]:
    """One listed body (i,) or pair (i, j), 0-based."""
    if kind.kind == "body":
        return (_body_index(item, n, where) - 1,)
    if isinstance(item, np.ndarray):
        item = item.tolist()
    if isinstance(item, (str, bytes)) or not isinstance(item, Sequence) or len(item) != 2:
        raise SpecError(f"{where}: expected a pair [i, j] of body indices 1..{n}, got {item!r}")
    i, j = (_body_index(b, n, where) for b in item)
    if i == j:
        raise SpecError(f"{where}: the pair [{i}, {j}] joins body {i} with itself")
    return (i - 1, j - 1)


def _body_index(value: Any, n: int, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise SpecError(f"{where}: expected a body index 1..{n}, got {value!r}")
    value = int(value)
    if not 1 <= value <= n:
        hint = " (indices are 1-based)" if value == 0 else ""
        raise SpecError(f"{where}: body {value} is not one of 1..{n}{hint}")
    return value


def _term_data(
    data: Any,
    kind: _TermKind,
    select: str,
    count: int,
    params: Mapping[str, float],
    where: str,
) -> tuple[TermData, ...]:
    """The data table: name = one number or 3-vector per member."""
    if data is None:
        return ()
    if not isinstance(data, Mapping):
        raise SpecError(f"{where} data: expected a table of name = list of values, got {data!r}")
    return tuple(
        _datum(name, values, kind, select, count, params, f"{where} data.{name}")
        for name, values in data.items()
    )


def _datum(
    name: Any,
    values: Any,
    kind: _TermKind,
    select: str,
    count: int,
    params: Mapping[str, float],
    where: str,
) -> TermData:
    """One datum: its name checked, one value per member, all numbers or all 3-vectors."""
    _check_data_name(name, params, where)
    if kind.kind == "pair" and select == "all":
        raise SpecError(
            f'{where}: per-pair data need an explicit list of pairs or "chain" '
            '(with pairs = "all", a value common to all pairs is a parameter)'
        )
    member = {"all": "body", "chain": "pair of the chain"}.get(select, f"listed {kind.kind}")
    entries = _rows(values, count, where, f"values (one per {member})")
    widths = [_entry_width(entry, f"{where}[{m + 1}]") for m, entry in enumerate(entries)]
    for m, width in enumerate(widths):
        if width != widths[0]:
            shown = {1: "a number", 3: "a 3-vector"}
            raise SpecError(
                f"{where}[{m + 1}]: {shown[width]}, but entry 1 is {shown[widths[0]]} "
                "(a datum is all numbers or all 3-vectors)"
            )
    flat = [
        _number(value, f"{where}[{m + 1}]" + (f"[{c + 1}]" if width == 3 else ""), params)
        for m, (entry, width) in enumerate(zip(entries, widths))
        for c, value in enumerate(_vector_items(entry) or [entry])
    ]
    return TermData(name, widths[0] if widths else 1, tuple(flat))


def _entry_width(entry: Any, where: str) -> int:
    """1 for a scalar entry, 3 for a 3-vector; anything else is an error."""
    if isinstance(entry, (str, sp.Expr)) or (
        isinstance(entry, numbers.Real) and not isinstance(entry, bool)
    ):
        return 1
    items = _vector_items(entry)
    if items is not None and len(items) == 3:
        return 3
    got = repr(entry) if items is None else f"a list of {len(items)}"
    raise SpecError(f"{where}: expected a number or a 3-vector, got {got}")


def _vector_items(entry: Any) -> list[Any] | None:
    """The components of a list-like entry (None if it is not one)."""
    if isinstance(entry, (np.ndarray, sp.MatrixBase)):
        return list(np.asarray(entry, dtype=object).ravel())
    if isinstance(entry, Sequence) and not isinstance(entry, (str, bytes)):
        return list(entry)
    return None


def _check_data_name(name: Any, params: Mapping[str, float], where: str) -> None:
    if not isinstance(name, str) or not name.isidentifier() or not name.isascii():
        raise SpecError(f"{where}: data name {name!r} is not an identifier")
    if keyword.iskeyword(name):
        raise SpecError(f"{where}: data name {name!r} is a reserved word")
    if name in params:
        raise SpecError(f"{where}: data name {name!r} clashes with the parameter {name!r}")
    if name in _ROLES:
        raise SpecError(
            f"{where}: data name {name!r} is reserved for a term's own vector (q, qi, qj)"
        )
    if name in RESERVED_NAMES or _Q_RESERVED.fullmatch(name):
        raise SpecError(
            f"{where}: data name {name!r} is a reserved name (q1.., e1..e3, pi and the "
            "function names have fixed meanings)"
        )


def _check_symbols(
    kind: _TermKind, data: Sequence[TermData], params: Mapping[str, float], where: str
) -> None:
    """No two of the parameters, the term's own vectors and its data may share a SymPy
    symbol (a vector datum r owns r_0, r_1, r_2; the vector q owns q_0, q_1, q_2)."""
    owners = {p: f"the parameter {p!r}" for p in params}
    claims = [(s.name, f"the term's vector {r}") for r in kind.roles for s in local_vector(r)]
    claims += [(s.name, f"the datum {d.name!r}") for d in data for s in d.symbols()]
    for symbol, owner in claims:
        if symbol in owners:
            raise SpecError(
                f"{where}: {owner} uses the symbol {symbol}, which is also {owners[symbol]} "
                "(rename one of them)"
            )
        owners[symbol] = owner


def _term_expression(
    value: Any,
    kind: _TermKind,
    n: int,
    local: Mapping[str, int],
    params: Mapping[str, float],
    where: str,
) -> sp.Expr:
    """A term's V: a string in its local names, or a SymPy scalar in their symbols."""
    if isinstance(value, str):
        return parse_expression(value, n=n, parameters=list(params), where=where, local=local)
    if isinstance(value, sp.MatrixBase):
        raise SpecError(f"{where}: the term is a {value.shape} matrix, not a scalar")
    if not isinstance(value, sp.Expr) and (
        isinstance(value, bool) or not isinstance(value, numbers.Real)
    ):
        raise SpecError(f"{where}: expected an expression string or a SymPy scalar, got {value!r}")
    expr = _scalar(value, where, list(params))
    own = " and ".join(kind.roles)
    names = {s.name for s in expr.free_symbols}
    global_q = sorted(name for name in names if _Q_RESERVED.fullmatch(name))
    if global_q:
        raise SpecError(
            f"{where}: the global positions {', '.join(global_q)} are not allowed in a term "
            f"expression (a term sees only its own vectors, here {own})"
        )
    allowed = {s.name for name, width in local.items() for s in _local_symbols(name, width)}
    extra = sorted(names - allowed - set(params))
    if extra:
        raise SpecError(
            f"{where}: depends on {', '.join(extra)}, which is not one of the term's vectors "
            f"({own}), its data or a parameter"
        )
    return expr


def _local_symbols(name: str, width: int) -> tuple[sp.Symbol, ...]:
    return local_vector(name) if width == 3 else (sp.Symbol(name, real=True),)


def _initial(
    value: Any, key: str, n: int, params: Mapping[str, float], origin: str
) -> list[list[float]] | None:
    """[initial] q or omega as n lists of 3 floats (shape and numbers checked here)."""
    if value is None:
        return None
    where = f"{origin}: [initial] {key}"
    rows = _rows(value, n, where, "vectors (one per body)")
    vectors = [_rows(row, 3, f"{where}[{i + 1}]", "components") for i, row in enumerate(rows)]
    return [
        [_number(v, f"{where}[{i + 1}][{c + 1}]", params) for c, v in enumerate(vector)]
        for i, vector in enumerate(vectors)
    ]


def _number(value: Any, where: str, params: Mapping[str, float]) -> float:
    """Evaluate a number or parameter expression to a finite float."""
    expr = _scalar(value, where, list(params))
    subs = {sp.Symbol(p, real=True): v for p, v in params.items()}
    extra = expr.free_symbols - set(subs)
    if extra:
        bad = ", ".join(sorted(str(s) for s in extra))
        raise SpecError(f"{where}: depends on {bad} (only numbers and parameters allowed)")
    try:
        result = float(expr.subs(subs).evalf())
    except (TypeError, ValueError):
        raise SpecError(f"{where}: {value!r} is not a real number") from None
    if not math.isfinite(result):
        raise SpecError(f"{where}: {value!r} is not finite")
    return result


def _run_settings(run: Any, origin: str) -> RunSettings:
    if run is None:
        return RunSettings()
    if isinstance(run, RunSettings):
        run = {k: v for k, v in asdict(run).items() if v is not None}
    if not isinstance(run, Mapping):
        raise SpecError(f"{origin}: [run]: expected a table, got {run!r}")
    _check_keys(run, ("h", "T", "method", "rtol", "atol"), f"{origin}: [run]")
    settings: dict[str, Any] = {}
    for key, value in run.items():
        where = f"{origin}: [run] {key}"
        if key != "method":
            settings[key] = _positive(value, where)
        elif value in METHODS:
            settings[key] = value
        else:
            raise SpecError(f"{where}: unknown method {value!r} (one of {', '.join(METHODS)})")
    return RunSettings(**settings)


def _positive(value: Any, where: str) -> float:
    number = float(value) if isinstance(value, numbers.Real) else math.nan
    if isinstance(value, bool) or not (math.isfinite(number) and number > 0):
        raise SpecError(f"{where}: expected a positive number, got {value!r}")
    return number


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise SpecError(f"{where}: unknown key {key!r} (allowed: {', '.join(allowed)})")


# ====================================================================== TOML files
_TOP_KEYS = ("name", "bodies", "parameters", "inertia", "potential", "initial", "run")
_TABLE_KEYS = {
    "parameters": None,
    "inertia": ("M", "diagonal"),
    "potential": ("V", "body", "pair"),
    "initial": ("q", "omega"),
    "run": ("h", "T", "method", "rtol", "atol"),
}


def load_spec(path: str | Path) -> System:
    """Read a TOML spec file and return its validated System (raises SpecError).

    Example:
        >>> from importlib.resources import files, as_file
        >>> with as_file(files("s2gen.systems.examples") / "double_pendulum.toml") as p:
        ...     load_spec(p).n
        2
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(f"{path}: no such spec file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: cannot read the spec file ({exc})") from None
    return load_spec_text(text, origin=str(path))


def load_spec_text(text: str, *, origin: str = "<string>") -> System:
    """Parse TOML spec text; `origin` names it in error messages (raises SpecError).

    Example:
        >>> load_spec_text('name = "p"\\nbodies = 1\\n[parameters]\\nm = 2.0\\n'
        ...                '[inertia]\\ndiagonal = ["m"]\\n[potential]\\nV = "q1[2]"\\n').inertia
        Matrix([[m]])
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{origin}: TOML syntax error: {exc}") from None
    _check_keys(data, _TOP_KEYS, f"{origin}: top level")
    for key in ("name", "bodies", "inertia", "potential"):
        if key not in data:
            raise SpecError(f"{origin}: missing required key {key!r}")
    tables = {key: _table(data, key, origin) for key in _TABLE_KEYS}
    potential = tables["potential"]
    if not {"V", "body", "pair"} & set(potential):
        raise SpecError(
            f"{origin}: [potential]: missing required key 'V' (required unless terms "
            "[[potential.body]] or [[potential.pair]] are given)"
        )
    return define_system(
        name=data["name"],
        bodies=data["bodies"],
        parameters=tables["parameters"],
        potential=potential.get("V"),
        inertia=tables["inertia"].get("M"),
        diagonal=tables["inertia"].get("diagonal"),
        initial_q=tables["initial"].get("q"),
        initial_omega=tables["initial"].get("omega"),
        run=tables["run"] or None,
        origin=origin,
        body_terms=potential.get("body"),
        pair_terms=potential.get("pair"),
    )


def _table(data: Mapping[str, Any], key: str, origin: str) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        raise SpecError(f"{origin}: {key!r} must be a table [{key}], got {table!r}")
    allowed = _TABLE_KEYS[key]
    if allowed is not None:
        _check_keys(table, allowed, f"{origin}: [{key}]")
    return table
