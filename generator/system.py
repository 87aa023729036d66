"""The validated, frozen description of a mechanical system on (S^2)^n.

Input: SymPy objects (inertia matrix, potential) and plain numbers (parameters, initial state,
run settings), from either front door (`spec.py` for TOML files and the Python API).
Output: a `System`, the single record every later stage reads.

Symbols: body i (1-based, as in the paper) has the unit vector q_i with components
``q_symbol(i, 0..2)`` (SymPy symbols named ``q{i}_{c}``); parameters are real SymPy symbols named
as declared. Validation errors are `SpecError`s naming the origin (file or API), the key and
the offending item; each part is checked by its module of `s2gen.validate`, terms and their
selections are `s2gen.terms`' records.

Example:
    >>> import sympy as sp
    >>> from s2gen.symbols import q_symbol
    >>> m, g = sp.symbols("m g", real=True)
    >>> s = System.create(name="pendulum", n=1, parameters={"m": 1.0, "g": 9.81},
    ...                   inertia=sp.Matrix([[m]]), potential=-m * g * q_symbol(1, 2))
    >>> s.n, s.parameter_names
    (1, ('m', 'g'))
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import sympy as sp

from s2gen.errors import SpecError, SpecWarning, shown
from s2gen.forces import Force, Inputs
from s2gen.inertia import ChainInertia, InertiaKind, InertiaStructure, chain_structure, detect
from s2gen.symbols import TIME
from s2gen.terms import Term, TermData
from s2gen.validate.forces import _check_inputs, _driven_symbols, _validate_force
from s2gen.validate.inertia import _validate_chain, _validate_matrix
from s2gen.validate.initial import UNIT_LENGTH_TOLERANCE, _validate_initial
from s2gen.validate.names import (
    MAX_NAME_LENGTH,
    _check_name,
    _check_parameters,
    _check_potential,
)
from s2gen.validate.terms import MAX_CUTOFF, _validate_term

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

#: The largest number of bodies a system may have (a larger one is refused before anything
#: is allocated; the emitted code's cost and the derivation's grow with n).
MAX_BODIES = 10**6
#: How the coupled solves are chosen: by the structure of M and n ("auto"), the dense
#: solvers, or the structured ones (an error when M has no structure they use).
INERTIA_SOLVERS = ("auto", "dense", "structured")


@dataclass(frozen=True)
class RunSettings:
    """Default run settings of a spec's [run] table (all optional)."""

    h: float | None = None
    T: float | None = None
    method: str | None = None
    rtol: float | None = None
    atol: float | None = None
    g: str | None = None  # the time-transformed methods' monitor R(q), spec text (s2gen.monitor)


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
    #: The driven part: the caller's inputs and the generalized forces (empty: closed system).
    inputs: Inputs = field(default_factory=Inputs)
    forces: tuple[Force, ...] = ()
    #: Whether the emitted C carries step_jacobian() (`with_jacobians`; off by default: it adds
    #: derivation and compile time)
    jacobians: bool = False
    #: Whether the emitted C carries integrate_batch() (`with_batch`; off by default: the
    #: modules of everyone else stay as they were)
    batch: bool = False
    #: What `s2gen.load` rebuilds this system from: a built-in name with its options
    #: (``elastic_rod:n=12``) or the TOML text; empty for a system defined in Python.
    source: str = field(default="", compare=False)
    #: The folder of the spec file the TOML `source` came from (absolute), where its relative
    #: data file names are found when it is rebuilt; empty otherwise.
    source_folder: str = field(default="", compare=False)

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
        inputs: Mapping[str, float] | None = None,
        forces: Sequence[Force] = (),
    ) -> System:
        """Validate the pieces and return a frozen System (raises SpecError).

        `inertia` is an n x n SymPy matrix or a `ChainInertia` (per-body expressions);
        `inertia_solver` one of `INERTIA_SOLVERS`. The potential and its terms may depend on
        time (`s2gen.symbols.TIME`) and the `inputs` (name -> default value); `forces` are
        `s2gen.forces.Force`s (see `s2gen.validate.forces`)."""
        where = origin
        _check_name(name, where)
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise SpecError(f"{where}: key 'bodies': expected a positive integer, got {shown(n)}")
        if n > MAX_BODIES:
            raise SpecError(
                f"{where}: key 'bodies': {n} bodies is more than the limit of {MAX_BODIES}"
            )
        n = int(n)
        names, values = _check_parameters(parameters, where)
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

        drive = _check_inputs(inputs or {}, set(names), where)
        driven = _driven_symbols(psyms, drive)
        V = _check_potential(potential, n, driven, where)

        for term in terms:
            timed = all(d.name != "t" for d in term.data)  # a datum t hides time
            _validate_term(term, n, driven if timed else driven - {TIME}, where)
        for force in forces:
            _validate_force(force, n, driven, where)
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
            inputs=drive,
            forces=tuple(forces),
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

    @cached_property
    def driven(self) -> bool:
        """True when the system has forces, inputs or a time-dependent potential (the part
        of the spec the emitted code does not handle yet). Computed once per system (a walk
        over the potential's expressions that every run would otherwise repeat).

        Example:
            >>> from s2gen.systems import builtin
            >>> builtin("double_pendulum").driven
            False
        """
        return bool(self.forces or self.inputs.names or self._timed())

    def _timed(self) -> list[str]:
        """The keys of the potential that depend on time (a parameter or datum named t is
        not time: it hides it, as in specs written before time existed)."""
        if "t" in self.parameter_names:
            return []
        keys = ["[potential] V"] if TIME in self.potential.free_symbols else []
        return keys + [
            f"{t.label} V"
            for t in self.terms
            if TIME in t.expr.free_symbols and all(d.name != "t" for d in t.data)
        ]

    def refuse_driven(self, what: str) -> None:
        """Raise a one-line SpecError naming the spec's first driven key when the system is
        `driven`: `what` (emitting code, the reference integrator) does not handle it yet.

        Example:
            >>> from s2gen.spec import define_system
            >>> s = define_system(name="p", bodies=1, parameters={}, diagonal=["1"],
            ...                   potential="cos(t)*q1[2]")
            >>> s.refuse_driven("emitting code")
            Traceback (most recent call last):
            ...
            s2gen.errors.SpecError: <python api>: [potential] V: t: emitting code for ...
        """
        if not self.driven:
            return
        if self.forces:
            key = self.forces[0].label
        elif self.inputs.names:
            key = f"[inputs] {self.inputs.names[0]}"
        else:
            key = f"{self._timed()[0]}: t"
        raise SpecError(
            f"{self.origin}: {key}: {what} for driven systems (forces, inputs or time t) is not "
            "supported yet; the spec is valid, but only a closed system can run"
        )

    def force_vectors(self) -> list[sp.Matrix]:
        """The total force F_i on each body, in q1..qn, w1..wn, t, inputs and parameters
        (small n only: for checks).

        Example:
            >>> from s2gen.spec import define_system
            >>> s = define_system(name="p", bodies=1, parameters={"c": 0.5}, diagonal=["1"],
            ...                   potential=0, forces={"F1": "-c*cross(w1, q1)"})
            >>> s.force_vectors()[0][2]
            0.5*q1_0*w1_1 - 0.5*q1_1*w1_0
        """
        total = [sp.zeros(3, 1) for _ in range(self.n)]
        for f in self.forces:
            for body, force in f.total(self.n):
                total[body] += force
        subs = dict(zip(self.parameter_symbols, self.parameter_values))
        return [sp.expand(v.xreplace(subs)) for v in total]

    def full_potential(self) -> sp.Expr:
        """V as one expression: the general part plus every term instance (small n only)."""
        total = self.potential
        for t in self.terms:
            total += sum(
                (t.instance(m, k) for k, m in enumerate(t.member_list(self.n))), sp.Integer(0)
            )
        return total

    def with_jacobians(self) -> System:
        """The same system, its emitted C with the step Jacobians (step_jacobian(): systems
        of at most 32 bodies without cutoff terms; see `s2gen.equations.jacobian`).

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> s.with_jacobians().jacobians, s.with_jacobians().spec_hash() != s.spec_hash()
            (True, True)
        """
        return dataclasses.replace(self, jacobians=True)

    def with_batch(self) -> System:
        """The same system, its emitted C with integrate_batch(): K members per call, SIMD
        across members (closed systems; see `s2gen.parts.batch`).

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("four_pendula")
            >>> s.with_batch().batch, s.with_batch().spec_hash() != s.spec_hash()
            (True, True)
        """
        return dataclasses.replace(self, batch=True)

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
            for d in t.body_data:  # none: the digest is unchanged
                h.update(f"body {d.name};{d.width};".encode())
                h.update(np.asarray(d.values, dtype=float).tobytes())
        if self.jacobians:  # absent by default: the digest is unchanged
            h.update(b"jacobians;")
        if self.batch:  # absent by default: the digest is unchanged
            h.update(b"batch;")
        if self.run.g is not None:  # the emitted monitor (absent by default: unchanged)
            h.update(f"monitor g={self.run.g};".encode())
        for u, v in zip(self.inputs.names, self.inputs.values):  # none: the digest is unchanged
            h.update(f"input {u}={v!r};".encode())
        for f in self.forces:
            h.update(f"force;{f.select};{f.members};{f.label};{f.global_}".encode())
            h.update(sp.srepr(f.expr).encode())
            for d in f.data:
                h.update(f"{d.name};{d.width};{d.values}".encode())
            for d in f.body_data:  # none: the digest is unchanged
                h.update(f"body {d.name};{d.width};".encode())
                h.update(np.asarray(d.values, dtype=float).tobytes())
        object.__setattr__(self, "_spec_digest", h.hexdigest())  # frozen: set once, by hand
        return h.hexdigest()
