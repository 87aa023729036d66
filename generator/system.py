"""The validated, frozen description of a mechanical system on (S^2)^n.

Input: SymPy objects (inertia matrix, potential) and plain numbers (parameters, initial state,
run settings), from either front door (`spec.py` for TOML files and the Python API).
Output: a `System`, the single record every later stage reads.

Symbols: body i (1-based, as in the paper) has the unit vector q_i with components
``q_symbol(i, 0..2)`` (SymPy symbols named ``q{i}_{c}``); parameters are real SymPy symbols named
as declared. Validation errors are `SpecError`s naming the origin (file or API), the key and
the offending item.

Example:
    >>> import sympy as sp
    >>> m, g = sp.symbols("m g", real=True)
    >>> s = System.create(name="pendulum", n=1, parameters={"m": 1.0, "g": 9.81},
    ...                   inertia=sp.Matrix([[m]]), potential=-m * g * q_symbol(1, 2))
    >>> s.n, s.parameter_names
    (1, ('m', 'g'))
"""

from __future__ import annotations

import hashlib
import keyword
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from s2gen.inertia import (
    INDEX,
    ChainInertia,
    InertiaKind,
    InertiaStructure,
    chain_cholesky_pivots,
    chain_structure,
    detect,
)
from s2gen.symbols import local_vector, q_symbol

__all__ = [
    "INERTIA_SOLVERS",
    "MAX_BODIES",
    "MAX_CUTOFF",
    "MAX_NAME_LENGTH",
    "UNIT_LENGTH_TOLERANCE",
    "RunSettings",
    "SpecError",
    "SpecWarning",
    "System",
    "Term",
    "TermData",
    "shown",
]

#: A q_i further than this from unit length is an error; closer ones are normalized (warning).
UNIT_LENGTH_TOLERANCE = 1e-3

#: The largest number of bodies a system may have (a larger one is refused before anything
#: is allocated; the emitted code's cost and the derivation's grow with n).
MAX_BODIES = 10**6
#: The longest system name: it prefixes every emitted symbol and names the emitted files.
MAX_NAME_LENGTH = 64
#: The largest pair-term cutoff: every pair of unit vectors lies within 2, and the emitted
#: code squares the cutoff, which must stay a finite double.
MAX_CUTOFF = 1e100

#: How the coupled solves are chosen: by the structure of M and n ("auto"), the dense
#: solvers, or the structured ones (an error when M has no structure they use).
INERTIA_SOLVERS = ("auto", "dense", "structured")

_C_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_C_RESERVED = frozenset(
    [
        "auto",
        "break",
        "case",
        "char",
        "const",
        "continue",
        "default",
        "do",
        "double",
        "else",
        "enum",
        "extern",
        "float",
        "for",
        "goto",
        "if",
        "inline",
        "int",
        "long",
        "register",
        "restrict",
        "return",
        "short",
        "signed",
        "sizeof",
        "static",
        "struct",
        "switch",
        "typedef",
        "union",
        "unsigned",
        "void",
        "volatile",
        "while",
        "main",
    ]
)


class SpecError(ValueError):
    """A system specification is invalid. The message names file/origin, key and item."""


def shown(value: object, limit: int = 60) -> str:
    """repr(value) for a one-line message, cut to `limit` characters (a value echoed in an
    error may be a 1000-digit string or a whole table)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    close = text[-1] if text[0] in "'\"" else ""  # a cut string keeps its closing quote
    return text[: limit - 3 - len(close)] + "..." + close


class SpecWarning(UserWarning):
    """A system specification was accepted after a small correction (e.g. normalization)."""


@dataclass(frozen=True)
class RunSettings:
    """Default run settings of a spec's [run] table (all optional)."""

    h: float | None = None
    T: float | None = None
    method: str | None = None
    rtol: float | None = None
    atol: float | None = None


@dataclass(frozen=True)
class TermData:
    """Per-member data of a term: `width` 1 (a scalar symbol `name`) or 3 (a vector, symbols
    name_0..2), with `width` values per member, member-major."""

    name: str
    width: int
    values: tuple[float, ...]

    def symbols(self) -> tuple[sp.Symbol, ...]:
        if self.width == 1:
            return (sp.Symbol(self.name, real=True),)
        return local_vector(self.name)


@dataclass(frozen=True)
class Term:
    """A structured part of the potential: a sum of one expression over a list of members.

    kind "body": expr in the body's vector q (symbols `local_vector("q")`), summed over bodies;
    kind "pair": expr in qi, qj, summed over pairs (i, j). `select` is "all" (every body, or
    every pair i < j), "chain" (pairs (i, i+1)) or "list" (`members`, 0-based). Per-member data
    (spring constants, offsets, ...) enter as extra symbols; parameters as usual.
    """

    kind: str
    expr: sp.Expr
    select: str = "all"
    members: tuple[tuple[int, ...], ...] = ()
    data: tuple[TermData, ...] = ()
    label: str = "term"
    cutoff: float | None = None  # pair terms over all pairs: only pairs with |q_i - q_j| < cutoff

    def count(self, n: int) -> int:
        """Number of members for n bodies."""
        if self.select == "list":
            return len(self.members)
        if self.kind == "body":
            return n
        return n - 1 if self.select == "chain" else n * (n - 1) // 2

    def member_list(self, n: int) -> list[tuple[int, ...]]:
        """The members (0-based) for n bodies, in loop order."""
        if self.select == "list":
            return list(self.members)
        if self.kind == "body":
            return [(i,) for i in range(n)]
        if self.select == "chain":
            return [(i, i + 1) for i in range(n - 1)]
        return [(i, j) for i in range(n) for j in range(i + 1, n)]

    def roles(self) -> tuple[str, ...]:
        return ("q",) if self.kind == "body" else ("qi", "qj")

    def position_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(s for role in self.roles() for s in local_vector(role))

    def data_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(s for d in self.data for s in d.symbols())

    def instance(self, member: tuple[int, ...], index: int) -> sp.Expr:
        """The term of one member written in the global symbols q{i}_{c} (for checks)."""
        subs: dict[sp.Symbol, sp.Expr] = {}
        for role, body in zip(self.roles(), member):
            subs.update(dict(zip(local_vector(role), (q_symbol(body + 1, c) for c in range(3)))))
        for d in self.data:
            vals = d.values[index * d.width : (index + 1) * d.width]
            subs.update({s: sp.Float(v) for s, v in zip(d.symbols(), vals)})
        return self.expr.xreplace(subs)


def _validate_term(term: Term, n: int, psyms: set[sp.Symbol], where: str) -> None:
    """Check kind, selection, members, data sizes and the symbols of one term."""
    at = f"{where}: {term.label}"
    if term.kind not in ("body", "pair"):
        raise SpecError(f"{at}: kind must be 'body' or 'pair', got {shown(term.kind)}")
    allowed = ("all", "list") if term.kind == "body" else ("all", "chain", "list")
    if term.select not in allowed:
        raise SpecError(f"{at}: selection must be one of {allowed}, got {shown(term.select)}")
    if term.select == "list":
        width = 1 if term.kind == "body" else 2
        for k, mem in enumerate(term.members):
            if len(mem) != width or not all(0 <= b < n for b in mem):
                one_based = [b + 1 for b in mem]
                raise SpecError(
                    f"{at}: member {k + 1} {one_based} is not {width} body index(es) 1..{n}"
                )
            if width == 2 and mem[0] == mem[1]:
                raise SpecError(f"{at}: member {k + 1} pairs body {mem[0] + 1} with itself")
    elif term.members:
        raise SpecError(f"{at}: members are given but the selection is {shown(term.select)}")
    if term.cutoff is not None:
        if term.kind != "pair" or term.select != "all":
            raise SpecError(f"{at}: a cutoff applies only to pair terms over all pairs")
        if not (np.isfinite(term.cutoff) and 0.0 < term.cutoff <= MAX_CUTOFF):
            raise SpecError(
                f"{at}: cutoff must be a positive distance of at most {MAX_CUTOFF:g} (unit "
                f"vectors lie within 2 of each other), got {shown(term.cutoff)}"
            )
    count = term.count(n)
    _check_data_names(term, at)
    for d in term.data:
        if term.select == "all" and term.kind == "pair":
            raise SpecError(
                f"{at}: per-pair data '{d.name}' needs an explicit pair list or a chain "
                "(a value common to all pairs is a parameter)"
            )
        if d.width not in (1, 3) or len(d.values) != d.width * count:
            got = len(d.values) / max(d.width, 1)
            raise SpecError(
                f"{at}: data '{d.name}' has {got:g} entries of width {d.width}, expected {count} "
                f"{'numbers' if d.width == 1 else '3-vectors'} (one per member)"
            )
        if not all(np.isfinite(d.values)):
            raise SpecError(f"{at}: data '{d.name}' contains a non-finite value")
    if not isinstance(term.expr, sp.Expr) or term.expr.has(sp.Derivative, sp.Integral):
        raise SpecError(f"{at}: must be a scalar expression without derivatives or integrals")
    names = [s.name for s in (*term.position_symbols(), *term.data_symbols())]
    clash = sorted(set(names) & {p.name for p in psyms}) or sorted(
        {x for x in names if names.count(x) > 1}
    )
    if clash:
        raise SpecError(f"{at}: symbol '{clash[0]}' is both a parameter/position and a datum")
    extra = term.expr.free_symbols - set(term.position_symbols()) - psyms - set(term.data_symbols())
    if extra:
        bad = ", ".join(sorted(str(s) for s in extra))
        raise SpecError(f"{at}: depends on {bad}, which is not a position, datum or parameter")
    _check_real(term.expr, f"{at} V")


#: Names of a term's emitted member tables: C `NAME_t<k>_i`, `_j`; NumPy `T<k>_I`, `_J` (data
#: tables are `NAME_t<k>_<name>` and `T<k>_<NAME>`, upper-cased, in the same namespaces).
_MEMBER_TABLES = frozenset({"I", "J"})


def _check_data_names(term: Term, at: str) -> None:
    """Data names must not clash with the emitted member tables of their term or the kernels'
    temporaries, nor with each other once upper-cased (the NumPy module's table names): k and
    K would share one table."""
    seen: dict[str, str] = {}
    for d in term.data:
        if not isinstance(d.name, str) or not _C_IDENTIFIER.fullmatch(d.name):
            raise SpecError(f"{at} data.{shown(d.name)}: {shown(d.name)} is not an identifier")
        if d.width == 1 and _TEMPORARY.fullmatch(d.name):  # a vector's symbols are x0_0..
            raise SpecError(f"{at} data.{d.name}: the name {shown(d.name)} {_TEMPORARY_CLASH}")
        upper = d.name.upper()
        if upper in _MEMBER_TABLES:
            raise SpecError(
                f"{at} data.{d.name}: the name {shown(d.name)} is taken by the term's table of "
                "member bodies in the emitted code (rename the datum)"
            )
        if upper in seen:
            raise SpecError(
                f"{at} data.{d.name}: the names {shown(seen[upper])} and {shown(d.name)} differ "
                "only in case, and the emitted NumPy module names its tables in upper case "
                "(rename one)"
            )
        seen[upper] = d.name


def _check_name(name: object, where: str) -> None:
    """The system name prefixes every emitted symbol and macro and names the files."""
    if not isinstance(name, str) or not _C_IDENTIFIER.fullmatch(name):
        raise SpecError(f"{where}: key 'name': {shown(name)} is not a C identifier")
    if len(name) > MAX_NAME_LENGTH:
        raise SpecError(
            f"{where}: key 'name': {shown(name[:16])}... has {len(name)} characters, more than the "
            f"limit of {MAX_NAME_LENGTH}"
        )
    if name.startswith("_"):
        raise SpecError(
            f"{where}: key 'name': {shown(name)} starts with '_' (C reserves such names, and the "
            f"header guard {name.upper()}_H could clash with a system header's)"
        )
    if name in _C_RESERVED or keyword.iskeyword(name):
        raise SpecError(f"{where}: key 'name': {shown(name)} is a reserved word in C or Python")


def _is_position(symbol: sp.Symbol, n: int) -> bool:
    """True for the position symbols q{i}_{c} of bodies 1..n (without building all 3n)."""
    match = _POSITION.fullmatch(symbol.name)
    return (
        match is not None
        and 1 <= int(match.group(1)) <= n
        and symbol == q_symbol(int(match.group(1)), int(match.group(2)))
    )


_POSITION = re.compile(r"q([1-9][0-9]*)_([0-2])")
#: The names of the emitted kernels' common-subexpression temporaries (`passes.cse`): real
#: symbols x0, x1, ... that a parameter or scalar datum of the same name would be taken for.
_TEMPORARY = re.compile(r"x[0-9]+")
_TEMPORARY_CLASH = "is reserved (the emitted code names its temporaries x0, x1, ...)"


def _check_real(expr: sp.Expr, where: str) -> None:
    """Refuse an expression that holds a complex number (sqrt(-1), log(-2), (-8)**(1/3)) or
    that SymPy knows is not real: the emitted code computes in real doubles."""
    bad: sp.Expr | None = sp.I if expr.has(sp.I) else None
    if bad is None:
        for atom in expr.atoms(sp.Pow, sp.Function):
            if not atom.free_symbols and atom.evalf(15).has(sp.I):
                bad = atom
                break
    if bad is None and expr.is_extended_real is False:
        bad = expr
    if bad is not None:
        text = str(bad) if len(str(bad)) <= 40 else str(bad)[:37] + "..."
        raise SpecError(f"{where}: is not real ({text} is complex); the potential must be real")


@dataclass(frozen=True)
class System:
    """A validated mechanical system on (S^2)^n. Build it with `System.create`.

    M is either a SymPy matrix (`matrix`) or per-body expressions (`chain`, never n^2
    entries); `inertia` is the matrix either way (built on demand), `structure` what it is.
    """

    name: str
    n: int
    parameter_names: tuple[str, ...]
    parameter_values: tuple[float, ...]
    matrix: sp.ImmutableSparseMatrix | None
    potential: sp.Expr
    q0: np.ndarray | None = field(default=None, compare=False)
    omega0: np.ndarray | None = field(default=None, compare=False)
    run: RunSettings = RunSettings()
    origin: str = "<python api>"
    terms: tuple[Term, ...] = ()
    chain: ChainInertia | None = None
    inertia_solver: str = "auto"
    #: What `s2gen.load` rebuilds this system from: a built-in name with its options
    #: (``elastic_rod:n=12``) or the TOML text; empty for a system defined in Python.
    source: str = field(default="", compare=False)

    # ------------------------------------------------------------------ construction
    @staticmethod
    def create(
        *,
        name: str,
        n: int,
        parameters: Mapping[str, float],
        inertia: sp.MatrixBase | ChainInertia,
        potential: sp.Expr,
        q0: Sequence[Sequence[float]] | np.ndarray | None = None,
        omega0: Sequence[Sequence[float]] | np.ndarray | None = None,
        run: RunSettings | None = None,
        origin: str = "<python api>",
        terms: Sequence[Term] = (),
        inertia_solver: str = "auto",
    ) -> System:
        """Validate the pieces and return a frozen System (raises SpecError).

        `inertia` is an n x n SymPy matrix or a `ChainInertia` (per-body expressions);
        `inertia_solver` one of `INERTIA_SOLVERS`."""
        where = origin
        _check_name(name, where)
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise SpecError(f"{where}: key 'bodies': expected a positive integer, got {shown(n)}")
        if n > MAX_BODIES:
            raise SpecError(
                f"{where}: key 'bodies': {n} bodies is more than the limit of {MAX_BODIES}"
            )
        n = int(n)
        names = tuple(parameters.keys())
        values: list[float] = []
        for pname in names:
            if not isinstance(pname, str) or not _C_IDENTIFIER.fullmatch(pname):
                raise SpecError(f"{where}: [parameters]: {shown(pname)} is not an identifier")
            if re.fullmatch(r"q[0-9]+_[0-9]+", pname):
                raise SpecError(
                    f"{where}: [parameters]: {shown(pname)} clashes with a position symbol"
                )
            if _TEMPORARY.fullmatch(pname):
                raise SpecError(f"{where}: [parameters]: {shown(pname)} {_TEMPORARY_CLASH}")
            try:
                v = float(parameters[pname])
            except (TypeError, ValueError):
                got = shown(parameters[pname])
                raise SpecError(
                    f"{where}: [parameters] {pname}: expected a number, got {got}"
                ) from None
            if not np.isfinite(v):
                raise SpecError(f"{where}: [parameters] {pname}: value {v} is not finite")
            values.append(v)
        psyms = {sp.Symbol(p, real=True) for p in names}
        subs = {sp.Symbol(p, real=True): v for p, v in zip(names, values)}

        if inertia_solver not in INERTIA_SOLVERS:
            raise SpecError(
                f"{where}: [inertia] solver: {inertia_solver!r} is not one of "
                f"{', '.join(INERTIA_SOLVERS)}"
            )
        if isinstance(inertia, ChainInertia):
            _validate_chain(inertia, n, psyms, subs, where)
            matrix = None
        else:
            matrix = _validate_matrix(inertia, n, psyms, subs, where)

        V = sp.sympify(potential)
        if not isinstance(V, sp.Expr):
            raise SpecError(f"{where}: [potential] V: must be a scalar expression, got {shown(V)}")
        extra = {s for s in V.free_symbols - psyms if not _is_position(s, n)}
        if extra:
            bad = ", ".join(sorted(str(s) for s in extra))
            raise SpecError(
                f"{where}: [potential] V: depends on {bad}; only q1..q{n} and the declared "
                "parameters may appear"
            )
        if V.has(sp.Derivative, sp.Integral):
            raise SpecError(f"{where}: [potential] V: must not contain derivatives or integrals")
        _check_real(V, f"{where}: [potential] V")

        for term in terms:
            _validate_term(term, n, psyms, where)
        q0a, w0a = _validate_initial(q0, omega0, n, where)
        return System(
            name=name,
            n=n,
            parameter_names=names,
            parameter_values=tuple(values),
            matrix=matrix,
            potential=V,
            q0=q0a,
            omega0=w0a,
            run=run or RunSettings(),
            origin=origin,
            terms=tuple(terms),
            chain=inertia if isinstance(inertia, ChainInertia) else None,
            inertia_solver=inertia_solver,
        )

    # ------------------------------------------------------------------ queries
    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        """Parameter symbols in declared order (the order of the emitted `p[]` array)."""
        return tuple(sp.Symbol(p, real=True) for p in self.parameter_names)

    @property
    def parameters(self) -> dict[str, float]:
        """Parameter values by name."""
        return dict(zip(self.parameter_names, self.parameter_values))

    @property
    def inertia(self) -> sp.ImmutableSparseMatrix:
        """M as a SymPy matrix (built from `chain` on first use: n^2 entries)."""
        if self.matrix is not None:
            return self.matrix
        cached = self.__dict__.get("_matrix")
        if cached is None:
            assert self.chain is not None
            cached = self.chain.matrix(self.n)
            object.__setattr__(self, "_matrix", cached)  # frozen: set once, by hand
        return cached  # type: ignore[no-any-return]

    @property
    def structure(self) -> InertiaStructure:
        """The structure of M (`s2gen.inertia`), found once and kept on the System."""
        cached = self.__dict__.get("_structure")
        if cached is None:
            subs = dict(zip(self.parameter_symbols, self.parameter_values))
            if self.chain is not None and self.is_diagonal:
                cached = InertiaStructure(InertiaKind.DIAGONAL, 0)
            elif self.chain is not None and chain_structure(self.chain, self.n, subs):
                cached = InertiaStructure(InertiaKind.MAX_INDEX, self.n - 1, (), self.chain)
            else:
                cached = detect(self.inertia, subs)
            object.__setattr__(self, "_structure", cached)
        return cached  # type: ignore[no-any-return]

    def inertia_numeric(self, values: Sequence[float] | None = None) -> np.ndarray:
        """M evaluated at the given (default: the spec's) parameter values."""
        vals = self.parameter_values if values is None else tuple(values)
        subs = dict(zip(self.parameter_symbols, vals))
        if self.chain is not None:
            return self.chain.dense(self.n, subs)
        out = np.zeros((self.n, self.n))
        for (r, c), entry in self.inertia.todok().items():
            out[r, c] = float(sp.sympify(sp.sympify(entry).xreplace(subs)).evalf())
        return out

    @property
    def is_diagonal(self) -> bool:
        """True when every off-diagonal entry of M is identically zero."""
        if self.chain is not None:
            return self.n == 1 or self.chain.max_index == 0 or self.chain.scale == 0
        return all(v == 0 for (r, c), v in self.inertia.todok().items() if r != c)

    def full_potential(self) -> sp.Expr:
        """V as one expression: the general part plus every term instance (small n only)."""
        total = self.potential
        for t in self.terms:
            total += sum(
                (t.instance(m, k) for k, m in enumerate(t.member_list(self.n))), sp.Integer(0)
            )
        return total

    def spec_hash(self) -> str:
        """A short content hash of the specification (goes into emitted preambles)."""
        return self.spec_digest()[:16]

    def spec_digest(self) -> str:
        """The sha256 (hex) of everything in the spec that the emitted code depends on
        (computed once per System and kept on it)."""
        cached = self.__dict__.get("_spec_digest")
        if cached is not None:
            return str(cached)
        h = hashlib.sha256()
        h.update(self.name.encode())
        h.update(str(self.n).encode())
        for p, v in zip(self.parameter_names, self.parameter_values):
            h.update(f"{p}={v!r};".encode())
        if self.chain is not None:
            h.update(f"chain;{self.n}".encode())
            for e in (self.chain.diagonal, self.chain.scale, self.chain.max_index):
                h.update(f"{sp.srepr(e)};".encode())
            for d in self.chain.data:
                h.update(f"{d.name};{d.values}".encode())
        else:
            for key, entry in sorted(self.inertia.todok().items()):
                h.update(f"{key}={sp.srepr(entry)};".encode())
        if self.inertia_solver != "auto":  # absent by default: older specs keep their digest
            h.update(f"solver={self.inertia_solver};".encode())
        h.update(sp.srepr(self.potential).encode())
        for t in self.terms:
            h.update(f"{t.kind};{t.select};{t.members};{t.label};{t.cutoff!r}".encode())
            h.update(sp.srepr(t.expr).encode())
            for d in t.data:
                h.update(f"{d.name};{d.width};{d.values}".encode())
        object.__setattr__(self, "_spec_digest", h.hexdigest())  # frozen: set once, by hand
        return h.hexdigest()


def _validate_matrix(
    inertia: sp.MatrixBase,
    n: int,
    psyms: set[sp.Symbol],
    subs: dict[sp.Symbol, float],
    where: str,
) -> sp.ImmutableSparseMatrix:
    """A given M: shape, constant entries (parameters only), symmetric, positive definite."""
    # SymPy's constructor sorts every entry (13 s for 10^5 bodies): keep a given one as is
    M = (
        inertia
        if isinstance(inertia, sp.ImmutableSparseMatrix)
        else sp.ImmutableSparseMatrix(inertia)
    )
    if M.shape != (n, n):
        raise SpecError(f"{where}: [inertia] M: expected a {n}x{n} matrix, got {M.shape}")
    entries = {key: sp.sympify(v) for key, v in M.todok().items()}
    checked: set[sp.Expr] = set()  # most entries repeat (uniform masses): check each once
    for (r, c), entry in sorted(entries.items()):
        if entry in checked:
            continue
        checked.add(entry)
        extra = entry.free_symbols - psyms
        if extra:
            bad = ", ".join(sorted(str(s) for s in extra))
            raise SpecError(
                f"{where}: [inertia] M[{r + 1}][{c + 1}]: depends on {bad}, "
                "but the inertia must be constant (parameters only)"
            )
    for (r, c), entry in sorted(entries.items()):
        other = entries.get((c, r), sp.Integer(0))
        upper_or_lone = r < c or (r > c and (c, r) not in entries)
        if upper_or_lone and entry != other and sp.simplify(entry - other) != 0:
            lo, hi = min(r, c), max(r, c)
            raise SpecError(
                f"{where}: [inertia] M is not symmetric: M[{lo + 1}][{hi + 1}] = "
                f"{M[lo, hi]} but M[{hi + 1}][{lo + 1}] = {M[hi, lo]}"
            )
    _check_positive_definite(entries, n, subs, where)
    return M


def _validate_chain(
    chain: ChainInertia,
    n: int,
    psyms: set[sp.Symbol],
    subs: dict[sp.Symbol, float],
    where: str,
) -> None:
    """Per-body inertia: its symbols, its data (one finite number per body), finite values
    and positive definiteness (an O(n) Cholesky; `s2gen.inertia.chain_cholesky_pivots`)."""
    names = [d.name for d in chain.data]
    for d in chain.data:
        if d.width != 1 or len(d.values) != n:
            raise SpecError(
                f"{where}: [inertia.data] {d.name}: expected {n} numbers (one per body), got "
                f"{len(d.values) / max(d.width, 1):g} entries of width {d.width}"
            )
        if not all(np.isfinite(d.values)):
            raise SpecError(f"{where}: [inertia.data] {d.name}: contains a non-finite value")
    clash = sorted(({p.name for p in psyms} | {INDEX.name}) & set(names))
    if clash or len(set(names)) != len(names):
        bad = clash[0] if clash else next(x for x in names if names.count(x) > 1)
        raise SpecError(
            f"{where}: [inertia.data] {bad}: the name is also a parameter, the body index i "
            "or another datum"
        )
    allowed = psyms | set(chain.data_symbols()) | {INDEX}
    for key, expr in (
        ("diagonal", chain.diagonal),
        ("scale", chain.scale),
        ("max_index", chain.max_index),
    ):
        if not isinstance(expr, sp.Expr):
            raise SpecError(f"{where}: [inertia] {key}: must be a scalar expression")
        extra = expr.free_symbols - allowed
        if extra:
            bad = ", ".join(sorted(str(s) for s in extra))
            raise SpecError(
                f"{where}: [inertia] {key}: depends on {bad}, which is not a parameter, "
                "a datum of [inertia.data] or the body index i"
            )
    try:
        d, a, c = chain.numeric(n, subs)
    except (TypeError, ValueError, ZeroDivisionError) as exc:
        raise SpecError(f"{where}: [inertia] cannot evaluate M per body ({exc})") from None
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(a)) and np.all(np.isfinite(c))):
        raise SpecError(f"{where}: [inertia] M is not finite at the parameter values")
    pivots = chain_cholesky_pivots(d, a, c)
    if not np.all(pivots > 0.0):
        k = int(np.argmin(np.nan_to_num(pivots, nan=np.inf) > 0.0))
        raise SpecError(
            f"{where}: [inertia] M is not positive definite at the parameter values "
            f"(Cholesky pivot {k + 1} is {pivots[k]:.6g})"
        )
    coupled = not (n == 1 or chain.max_index == 0 or chain.scale == 0)
    if coupled and not chain_structure(chain, n, subs):
        warnings.warn(
            f"{where}: [inertia]: the O(n) solvers need scale != 0 at every body and "
            "max_index_k != max_index_k+1 (max_index_n != 0); M is treated as a general "
            "matrix (n^2 entries, dense solves)",
            SpecWarning,
            stacklevel=4,
        )


def _check_positive_definite(
    entries: dict[tuple[int, int], sp.Expr], n: int, subs: dict[sp.Symbol, float], where: str
) -> None:
    """M must be real, finite and positive definite at the parameter values."""
    values: dict[tuple[int, int], float] = {}
    cache: dict[sp.Expr, float] = {}
    for key, entry in entries.items():
        if entry not in cache:
            try:
                cache[entry] = float(sp.sympify(entry.xreplace(subs)).evalf())
            except (TypeError, ValueError):
                msg = f"{where}: [inertia] M is not real at the parameter values"
                raise SpecError(msg) from None
        values[key] = cache[entry]
    if not all(np.isfinite(v) for v in values.values()):
        raise SpecError(f"{where}: [inertia] M is not finite at the parameter values")
    if all(r == c for r, c in values):
        diag = np.array([values.get((i, i), 0.0) for i in range(n)])
        smallest = float(diag.min())
    else:
        dense = np.zeros((n, n))
        for (r, c), v in values.items():
            dense[r, c] = v
        smallest = float(np.linalg.eigvalsh(dense)[0])
    if smallest <= 0.0:
        raise SpecError(
            f"{where}: [inertia] M is not positive definite at the parameter values "
            f"(smallest eigenvalue {smallest:.6g})"
        )


def _validate_initial(
    q0: Sequence[Sequence[float]] | np.ndarray | None,
    omega0: Sequence[Sequence[float]] | np.ndarray | None,
    n: int,
    where: str,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Check shapes, normalize q_i rounded to printed digits, project omega_i on T_q S^2."""
    if q0 is None and omega0 is None:
        return None, None
    if q0 is None or omega0 is None:
        raise SpecError(f"{where}: [initial]: give both 'q' and 'omega' (or neither)")
    try:
        q = np.array(q0, dtype=float)
        w = np.array(omega0, dtype=float)
    except (TypeError, ValueError) as exc:
        raise SpecError(f"{where}: [initial]: not a list of numeric 3-vectors ({exc})") from None
    for key, arr in (("q", q), ("omega", w)):
        if arr.shape != (n, 3):
            raise SpecError(
                f"{where}: [initial] {key}: expected {n} vectors of 3 components, "
                f"got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise SpecError(f"{where}: [initial] {key}: contains a non-finite value")
    norms = np.linalg.norm(q, axis=1)
    notes = []
    for i in range(n):
        dev = abs(norms[i] - 1.0)
        if dev > UNIT_LENGTH_TOLERANCE:
            raise SpecError(
                f"{where}: [initial] q{i + 1}: length {norms[i]:.6g} is not a unit vector "
                f"(off by {dev:.3g} > {UNIT_LENGTH_TOLERANCE:g})"
            )
        if dev > 8 * np.finfo(float).eps:
            notes.append(f"q{i + 1} normalized (length was 1{norms[i] - 1.0:+.3g})")
    qn = q / norms[:, None]
    radial = np.einsum("ij,ij->i", qn, w)
    wn = w - radial[:, None] * qn
    for i in range(n):
        scale = max(1.0, float(np.linalg.norm(w[i])))
        if abs(radial[i]) > UNIT_LENGTH_TOLERANCE * scale:  # as q_i's length: not round-off
            raise SpecError(
                f"{where}: [initial] omega{i + 1}: its component {radial[i]:.6g} along q{i + 1} is "
                f"more than {UNIT_LENGTH_TOLERANCE:g} of max(1, |omega{i + 1}|); omega must be "
                "tangent to the sphere (omega_i . q_i = 0)"
            )
        if radial[i] != 0.0 and abs(radial[i]) > 4 * np.finfo(float).eps * scale:
            notes.append(
                f"omega{i + 1} projected onto the tangent plane (removed {radial[i]:+.3g})"
            )
    if notes:
        warnings.warn(f"{where}: [initial]: " + "; ".join(notes), SpecWarning, stacklevel=3)
    return qn, wn
