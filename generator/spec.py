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

from .system import RunSettings, SpecError, System, q_vector

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
class _Context:
    """What a parse may see, plus what it needs to point at the offending token."""

    body: str  # the text given to ast.parse
    where: str
    n: int
    parameters: frozenset[str]
    allow_vectors: bool
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
) -> sp.Expr:
    """Parse a scalar expression of the spec language into SymPy, safely (raises SpecError).

    With ``allow_vectors=False`` only numbers, parameters, pi and scalar functions may appear
    (used for inertia entries and initial values).

    Example:
        >>> parse_expression("m*g*dot(e3, q1) + q2[0]/2", n=2, parameters=["m", "g"],
        ...                  where="spec.toml: [potential] V")
        g*m*q1_2 + q2_0/2
    """
    bad = [p for p in parameters if p in RESERVED_NAMES or _Q_RESERVED.fullmatch(p)]
    if bad:
        raise SpecError(f"{where}: parameter name {bad[0]!r} is reserved")
    ctx, tree = _parse(text, where, n, parameters, allow_vectors)
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


def _parse(
    text: str, where: str, n: int, parameters: Sequence[str], allow_vectors: bool
) -> tuple[_Context, ast.Expression]:
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
        n=n,
        parameters=frozenset(parameters),
        allow_vectors=allow_vectors,
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
    if name in ctx.parameters:
        return sp.Symbol(name, real=True)
    if name == "pi":
        return sp.pi
    if name in _SCALAR_FUNCTIONS or name in _VECTOR_FUNCTIONS:
        raise ctx.fail(node, f"function {name!r} used without a call, e.g. {name}(...)")
    match = _Q_NAME.fullmatch(name)
    if (match or name in _AXES) and not ctx.allow_vectors:
        raise ctx.fail(node, f"{name!r} is not allowed here (only numbers and parameters)")
    if name in _AXES:
        return _AXES[name]
    if match and 1 <= int(match.group(1)) <= ctx.n and not name.startswith("q0"):
        return sp.ImmutableMatrix(q_vector(int(match.group(1))))
    if match:
        raise ctx.fail(node, f"no body {name!r}: the bodies are q1..q{ctx.n}")
    raise ctx.fail(node, f"unknown name {name!r}")


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
    if name in _VECTOR_FUNCTIONS and not ctx.allow_vectors:
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
    potential: str | float | sp.Expr,
    inertia: Sequence[Sequence[str | float | sp.Expr]] | sp.MatrixBase | None = None,
    diagonal: Sequence[str | float | sp.Expr] | None = None,
    initial_q: Sequence[Sequence[str | float | sp.Expr]] | np.ndarray | None = None,
    initial_omega: Sequence[Sequence[str | float | sp.Expr]] | np.ndarray | None = None,
    run: Mapping[str, Any] | RunSettings | None = None,
    origin: str = API_ORIGIN,
) -> System:
    """Build a validated System from Python values (the same rules as a TOML spec).

    Expressions may be strings (parsed safely) or SymPy objects; give exactly one of
    `inertia` (n x n) and `diagonal` (n entries). Raises SpecError naming `origin` and the key.

    Example:
        >>> s = define_system(name="pend", bodies=1, parameters={"m": 1.0, "l": 2.0},
        ...                   inertia=[["m*l**2"]], potential="-m*9.81*l*q1[2]",
        ...                   initial_q=[["sqrt(3)/2", 0, "1/2"]], initial_omega=[[0, 1, 0]])
        >>> s.inertia, s.q0.round(4).tolist()
        (Matrix([[l**2*m]]), [[0.866, 0.0, 0.5]])
    """
    params = _parameters(parameters, origin)
    n = _bodies(bodies, origin)
    names = list(params)
    return System.create(
        name=name,
        n=n,
        parameters=params,
        inertia=_inertia(inertia, diagonal, n, names, origin),
        potential=_potential(potential, n, names, origin),
        q0=_initial(initial_q, "q", n, params, origin),
        omega0=_initial(initial_omega, "omega", n, params, origin),
        run=_run_settings(run, origin),
        origin=origin,
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
    "potential": ("V",),
    "initial": ("q", "omega"),
    "run": ("h", "T", "method", "rtol", "atol"),
}


def load_spec(path: str | Path) -> System:
    """Read a TOML spec file and return its validated System (raises SpecError).

    Example:
        >>> from importlib.resources import files, as_file
        >>> with as_file(files("s2gen.examples") / "double_pendulum.toml") as p:
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
    if "V" not in tables["potential"]:
        raise SpecError(f"{origin}: [potential]: missing required key 'V'")
    return define_system(
        name=data["name"],
        bodies=data["bodies"],
        parameters=tables["parameters"],
        potential=tables["potential"]["V"],
        inertia=tables["inertia"].get("M"),
        diagonal=tables["inertia"].get("diagonal"),
        initial_q=tables["initial"].get("q"),
        initial_omega=tables["initial"].get("omega"),
        run=tables["run"] or None,
        origin=origin,
    )


def _table(data: Mapping[str, Any], key: str, origin: str) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        raise SpecError(f"{origin}: {key!r} must be a table [{key}], got {table!r}")
    allowed = _TABLE_KEYS[key]
    if allowed is not None:
        _check_keys(table, allowed, f"{origin}: [{key}]")
    return table
