"""The spec's expression language: a whitelisted walk over Python's `ast`, never evaluated.

Input: an expression string, the number of bodies, the declared parameter names, a location
for messages (`where`) and what the expression may see (vectors or only numbers and
parameters; a term's local names).
Output: a scalar SymPy expression from `parse_expression` (vectors such as q1 or qi are 3x1
matrices while parsing and must end in a scalar), or a `SpecError` naming `where`, the
offending token and its line and column (1-based, within the string). What names mean is
`s2gen.spec.names`', which numbers may appear `s2gen.spec.numbers`' and where a token is in
the text `s2gen.spec.source`'. The language itself is described in the package docstring
(`s2gen.spec`).
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.spec.names import (
    _Q_RESERVED,
    _SCALAR_FUNCTIONS,
    _VECTOR_FUNCTIONS,
    RESERVED_NAMES,
    Value,
    _name_table,
    _Names,
)
from s2gen.spec.numbers import _MAX_DIGITS, _digits, _number_problem
from s2gen.spec.source import _check_characters, _Context

__all__ = ["RESERVED_NAMES", "Value", "parse_expression", "parse_vector"]

#: Limits of the language, each stated in the error that enforces it.
_MAX_LENGTH = 100_000  # characters of one expression
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


def parse_expression(
    text: str,
    *,
    n: int,
    parameters: Sequence[str],
    where: str,
    allow_vectors: bool = True,
    local: Mapping[str, int] | None = None,
    velocities: bool = False,
) -> sp.Expr:
    """Parse a scalar expression of the spec language into SymPy, safely (raises SpecError).

    With ``allow_vectors=False`` only numbers, parameters, pi and scalar functions may appear
    (used for inertia entries and initial values). `local` makes it a term expression: it maps
    the term's own names (its vectors q, or qi and qj, and its data) to their widths, 3 for a
    vector (symbols name_0..name_2, see `local_vector`) or 1 for a scalar (the symbol name);
    the global q1..qn are then refused. Time `t` is a name wherever vectors are allowed;
    `velocities` adds the angular velocities w1..wn (a force's expression, see
    `parse_vector`).

    Example:
        >>> parse_expression("m*g*dot(e3, q1) + q2[0]/2", n=2, parameters=["m", "g"],
        ...                  where="spec.toml: [potential] V")
        g*m*q1_2 + q2_0/2
        >>> parse_expression("k*(dot(r, qj) - 1) + qi[2]", n=2, parameters=["k"],
        ...                  where="spec.toml: [[potential.pair]] #1 V",
        ...                  local={"qi": 3, "qj": 3, "r": 3})
        k*(qj_0*r_0 + qj_1*r_1 + qj_2*r_2 - 1) + qi_2
    """
    ctx, tree, result = _parse_value(text, n, parameters, where, allow_vectors, local, velocities)
    if isinstance(result, sp.MatrixBase):
        raise ctx.fail(
            tree.body,
            f"the expression {ctx.token(tree.body)!r} is a vector, but a scalar is required "
            "(use dot(a, b) or a component such as q1[2])",
        )
    if result.is_extended_real is False:
        raise ctx.fail(tree.body, f"the expression {ctx.token(tree.body)!r} is not real")
    return result


def parse_vector(
    text: str,
    *,
    n: int,
    parameters: Sequence[str],
    where: str,
    local: Mapping[str, int] | None = None,
) -> sp.ImmutableMatrix:
    """Parse a 3-vector expression (a force) in q1..qn, w1..wn, t and the parameters, or in a
    term's own `local` names (then q and w, say), safely (raises SpecError).

    Example:
        >>> parse_vector("c*cos(t)*e3 - w1[0]*e1", n=1, parameters=["c"], where="F1").T
        Matrix([[-w1_0, 0, c*cos(t)]])
    """
    ctx, tree, result = _parse_value(text, n, parameters, where, True, local, True)
    if not isinstance(result, sp.MatrixBase):
        raise ctx.fail(
            tree.body,
            f"the expression {ctx.token(tree.body)!r} is a scalar, but a force is a 3-vector "
            "(e.g. f*e3 or cross(tau, q1))",
        )
    if any(entry.is_extended_real is False for entry in result):
        raise ctx.fail(tree.body, f"the expression {ctx.token(tree.body)!r} is not real")
    return sp.ImmutableMatrix(result)


def _parse_value(
    text: str,
    n: int,
    parameters: Sequence[str],
    where: str,
    allow_vectors: bool,
    local: Mapping[str, int] | None,
    velocities: bool,
) -> tuple[_Context, ast.Expression, Value]:
    """Check the parameter names, parse `text` and walk it: scalar or vector."""
    bad = [p for p in parameters if p in RESERVED_NAMES or _Q_RESERVED.fullmatch(p)]
    if bad:
        raise SpecError(f"{where}: parameter name {shown(bad[0])} is reserved")
    names = _name_table(n, parameters, allow_vectors, local, where, velocities and not local)
    ctx, tree = _parse(text, where, names)
    try:
        return ctx, tree, _eval(ctx, tree.body)
    except RecursionError:
        raise SpecError(f"{where}: expression nested too deeply") from None


def _parse(text: str, where: str, names: _Names) -> tuple[_Context, ast.Expression]:
    """Parse `text` (leading whitespace dropped: ast would call it an indent) into a tree.

    A multi-line text that is not valid as written is retried inside parentheses, so long
    TOML strings may break lines anywhere, as inside parentheses.
    """
    if not isinstance(text, str):
        raise SpecError(f"{where}: expected an expression string, got {shown(text)}")
    if len(text) > _MAX_LENGTH:
        raise SpecError(f"{where}: expression longer than the limit of {_MAX_LENGTH} characters")
    _check_characters(text, where)
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
    """`value` if every number in it can be a double; else an error located at `node`."""
    entries = value if isinstance(value, sp.MatrixBase) else [value]
    for entry in entries:
        problem = _number_problem(entry)
        if problem is not None:
            raise ctx.fail(node, f"{ctx.token(node)!r} {problem}")
    return value


def _constant(ctx: _Context, node: ast.Constant) -> Value:
    value = node.value
    if isinstance(value, bool):
        raise ctx.fail(node, f"boolean {shown(value)} is not allowed")
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
        raise ctx.fail(node, f"function {shown(name)} used without a call, e.g. {name}(...)")
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
    """Refuse numeric powers whose exact value SymPy would compute with more than _MAX_DIGITS
    digits (before SymPy computes it: sqrt(3)**(10**8) is 3**(5*10**7), which takes minutes)."""
    if not isinstance(exponent, sp.Number):
        return
    size = abs(float(exponent)) * _digits(base)
    if size > _MAX_DIGITS:
        raise ctx.fail(
            ctx.operator(node),
            f"power {ctx.token(node)!r} is too large: its exact value would have about "
            f"{size:.2g} digits, more than the limit of {_MAX_DIGITS}",
        )


def _call(ctx: _Context, node: ast.Call) -> Value:
    if not isinstance(node.func, ast.Name):
        what = _NODE_NAMES.get(type(node.func), "calling")
        raise ctx.fail(node.func, f"{what} {ctx.token(node.func)!r} is not allowed")
    name = node.func.id
    if name not in _SCALAR_FUNCTIONS and name not in _VECTOR_FUNCTIONS:
        known = ", ".join(sorted([*_SCALAR_FUNCTIONS, *_VECTOR_FUNCTIONS]))
        raise ctx.fail(node.func, f"{shown(name)} is not a known function (known: {known})")
    if name in _VECTOR_FUNCTIONS and not ctx.names.allow_vectors:
        raise ctx.fail(node.func, f"function {shown(name)} is not allowed here (no vectors)")
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
