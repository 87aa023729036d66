"""The spec's expression language: a whitelisted walk over Python's `ast`, never evaluated.

Input: an expression string, the number of bodies, the declared parameter names, a location
for messages (`where`) and what the expression may see (vectors or only numbers and
parameters; a term's local names).
Output: a scalar SymPy expression from `parse_expression` (vectors such as q1 or qi are 3x1
matrices while parsing and must end in a scalar), or a `SpecError` naming `where`, the
offending token and its line and column (1-based, within the string). Also the name tables:
`RESERVED_NAMES` (pi, the functions, e1..e3), the global body vectors q1..qn and the term
roles q, qi, qj. The language itself is described in the package docstring (`s2gen.spec`).
"""

from __future__ import annotations

import ast
import math
import operator
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypeAlias

import sympy as sp

from s2gen.symbols import local_vector, q_vector
from s2gen.system import SpecError, shown
from s2gen.terms import TermKind

__all__ = ["RESERVED_NAMES", "Value", "parse_expression"]

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
_ROLES = tuple(role for kind in TermKind for role in kind.roles)
#: Limits of the language, each stated in the error that enforces it.
_MAX_LENGTH = 100_000  # characters of one expression
_MAX_DIGITS = 1000  # decimal digits of an exact number (numerator and denominator together)
_MAX_LITERAL_DIGITS = 400  # digits of one number as written
#: The largest finite double: every number, as written or computed, must stay within it.
DOUBLE_MAX = sys.float_info.max
_NON_FINITE = (sp.zoo, sp.oo, sp.S.NegativeInfinity, sp.nan)
#: Characters an expression may contain: printable ASCII and line breaks, but no '#'.
_ALLOWED = frozenset(chr(c) for c in range(0x20, 0x7F)) | {"\t", "\n", "\r"}
_LONG_DIGITS = re.compile(f"[0-9_]{{{_MAX_LITERAL_DIGITS + 1},}}")

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
            return f"{shown(name)} is not allowed here (only numbers and parameters)"
        own = " and ".join(self.roles)
        if global_q and self.term:
            return (
                f"the global position {shown(name)} is not allowed in a term expression "
                f"(a term sees only its own vectors, here {own})"
            )
        if global_q:
            return f"no body {shown(name)}: the bodies are q1..q{self.n}"
        if name in _ROLES and self.term:
            return f"unknown name {shown(name)} (this term's own vectors are {own})"
        if name in _ROLES:
            return (
                f"unknown name {shown(name)} (q, qi and qj exist only in term expressions: "
                "[[potential.body]] has q, [[potential.pair]] has qi and qj)"
            )
        return f"unknown name {shown(name)}"


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
        raise SpecError(f"{where}: parameter name {shown(bad[0])} is reserved")
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
    if result.is_extended_real is False:
        raise ctx.fail(tree.body, f"the expression {ctx.token(tree.body)!r} is not real")
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
            raise SpecError(
                f"{where}: local name {shown(name)} clashes with {what} name {shown(name)}"
            )
        if width not in (1, 3):
            raise SpecError(f"{where}: local name {shown(name)} has width {width}, not 1 or 3")
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


def _check_characters(text: str, where: str) -> None:
    """Refuse what Python's tokenizer would read differently from the language: '#' (a
    comment that silently drops the rest of the line), characters outside printable ASCII
    (identifiers are NFKC-normalized, so a full-width 'ｍ' would read as 'm') and numbers too
    long to be a double (Python refuses to convert more than 4300 digits)."""
    bad = next((k for k, ch in enumerate(text) if ch == "#" or ch not in _ALLOWED), None)
    if bad is not None:
        ch = text[bad]
        if ch == "#":
            why = "'#' is not allowed (expressions have no comments; it would end the expression)"
        else:
            why = f"character {ch!r} (U+{ord(ch):04X}) is not allowed (expressions are ASCII)"
        raise SpecError(f"{where}: {why} at {_text_position(text, bad)}")
    long = _LONG_DIGITS.search(text)
    if long is not None:
        raise SpecError(
            f"{where}: number {long.group()[:12] + '...'!r} has more than the limit of "
            f"{_MAX_LITERAL_DIGITS} digits (a double is at most about 1.8e308) at "
            f"{_text_position(text, long.start())}"
        )


def _text_position(text: str, index: int) -> str:
    """'column C' or 'line L, column C' (1-based) of `text[index]`, lines split as ast does."""
    lines = re.split(r"\r\n|\r|\n", text[:index])
    line, col = len(lines), len(lines[-1])
    return f"column {col + 1}" if line == 1 else f"line {line}, column {col + 1}"


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


def _number_problem(expr: sp.Expr) -> str | None:
    """Why `expr` cannot be computed in doubles as C, NumPy and the reference do (None if it
    can): a non-finite number, an exact number too long to handle, a number beyond the range
    of a double, or a constant that is not real."""
    symbolic = False
    for atom in expr.atoms(sp.Number, sp.Symbol, type(sp.zoo)):
        if isinstance(atom, sp.Symbol):
            symbolic = True
        elif atom in _NON_FINITE:
            return "is not finite (division by zero?)"
        elif isinstance(atom, sp.Rational) and _digits(atom) > _MAX_DIGITS:
            return f"holds an exact number of more than the limit of {_MAX_DIGITS} digits"
        elif abs(atom) > DOUBLE_MAX:
            return f"holds the number {_short(atom)}, beyond the range of a double ({_RANGE})"
    if symbolic or isinstance(expr, sp.Number):
        return None
    value = expr.evalf(17)
    if value.has(sp.I):
        return f"is not real (it is {_short(value)})"
    if isinstance(value, sp.Float) and abs(value) > DOUBLE_MAX:
        return f"is about {_short(value)}, beyond the range of a double ({_RANGE})"
    return None


_RANGE = "magnitude at most about 1.8e308"
_LOG10_2 = math.log10(2.0)


def _short(value: sp.Expr) -> str:
    """A number for a message: a few significant digits, never thousands (an exponent of
    more than 12 digits is given by its length: 5.957e+<233 digits>).

    Example:
        >>> _short(sp.Integer(10) ** 400), _short(sp.Float("1e300") ** (10**200))
        ('1.000e+400', '1.000e+<203 digits>')
    """
    if isinstance(value, (sp.Integer, sp.Float)):
        text = str(sp.Float(value, 4)) if abs(value) >= 1e6 else str(value)
    else:
        text = str(sp.N(value, 4))
    mantissa, e, exponent = text.partition("e")
    if e and len(exponent.lstrip("+-")) > 12:
        return f"{mantissa}e{exponent[0]}<{len(exponent.lstrip('+-'))} digits>"
    return text if len(text) <= 60 else text[:57] + "..."


def _digits(value: sp.Expr) -> float:
    """About how many decimal digits SymPy computes exactly when it raises `value` to the
    power 1 (an upper bound of the work of `value**e` is |e| times this): the digits of exact
    numbers, including those SymPy distributes a power over (products and powers of powers);
    0 for floats (mpmath powers are cheap) and for what SymPy leaves unevaluated."""
    if isinstance(value, sp.Rational):
        return (_log10(abs(int(value.p))) + _log10(int(value.q))) or 0.0
    if isinstance(value, sp.Mul):
        return sum(_digits(arg) for arg in value.args)
    if isinstance(value, sp.Pow) and isinstance(value.exp, sp.Number):
        return abs(float(value.exp)) * _digits(value.base)
    return 0.0


def _log10(n: int) -> float:
    """A lower bound of log10(n) for n >= 1 (0 for 0 and 1), without converting n to float."""
    return max(n.bit_length() - 1, 0) * _LOG10_2


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
