"""A mechanical system on (S^2)^n in numbers, from a `System` or by hand.

Input: a `System` (inertia matrix, general potential, structured terms, parameters) and
optionally parameter values; or M, V and dV/dq given directly.
Output: a `ReferenceProblem` (M (n, n), `potential` q -> V, `grad` q -> dV/dq (n, 3)). The
general potential is differentiated by SymPy in the 3n global symbols; each structured term is
differentiated once in its local symbols and evaluated vectorized over its members (a
`_TermKernel`), never expanded per member.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from s2gen.symbols import q_symbols
from s2gen.system import System, Term
from s2gen.terms import Selection

__all__ = [
    "ANALYTIC",
    "Array",
    "GradFn",
    "PotentialFn",
    "ReferenceProblem",
    "numbers",
    "problem_from_system",
    "scalar",
]

Array = np.ndarray
GradFn = Callable[[Array], Array]
PotentialFn = Callable[[Array], float]


def numbers(a: Any) -> Array:
    """`a` as a float array, or as a complex array when it holds complex numbers: the
    reference's steps carry complex states, inputs and parameters for a complex-step
    derivative (`s2gen.reference.step_jacobian`), and a real input is cast exactly as before.

    Example:
        >>> numbers([1, 2]).dtype, numbers([1j]).dtype
        (dtype('float64'), dtype('complex128'))
    """
    arr = np.asarray(a)
    return arr if np.iscomplexobj(arr) else np.asarray(a, dtype=float)


def scalar(x: Any) -> Any:
    """`x` as a Python float, or complex when it is complex (see `numbers`).

    Example:
        >>> scalar(np.float64(0.5)), scalar(np.complex128(1j))
        (0.5, 1j)
    """
    return complex(x) if np.iscomplexobj(x) else float(x)


def _abs(x: Any) -> Any:
    """|x| for real x (Python's abs, as lambdify prints it); for complex x the analytic
    continuation of |Re x|, x sign(Re x), so that a complex-step derivative of |x| is
    sign(x) dx (NumPy's |x| of a complex number is the modulus, which drops it)."""
    if not np.iscomplexobj(x):
        return abs(x)
    return np.where(np.real(x) < 0, -x, x)


def _sign(x: Any) -> Any:
    """sign(x) for real x (NumPy's); for complex x the sign of the real part (constant
    nearby: derivative 0; NumPy's sign of a complex number is x/|x|)."""
    return np.sign(np.real(x)) if np.iscomplexobj(x) else np.sign(x)


#: The functions lambdify takes from here before NumPy: those that are not analytic in NumPy's
#: complex arithmetic (`_abs`, `_sign`); on real arguments they are what NumPy computes.
ANALYTIC: dict[str, Callable[..., Any]] = {"Abs": _abs, "sign": _sign}
MODULES: list[Any] = [ANALYTIC, "numpy"]


@dataclass(frozen=True)
class ReferenceProblem:
    """A mechanical system on (S^2)^n in numbers: L = 1/2 sum M_ij qdot_i.qdot_j - V(q).

    `grad` maps q (n, 3) to dV/dq (n, 3); `potential` maps q (n, 3) to V (float).

    Example:
        >>> p = ReferenceProblem(np.eye(2), lambda q: np.zeros_like(q), lambda q: 0.0)
        >>> p.n, p.is_diagonal
        (2, True)
    """

    M: Array
    grad: GradFn
    potential: PotentialFn

    def __post_init__(self) -> None:
        M = np.array(numbers(self.M))
        if M.ndim != 2 or M.shape[0] != M.shape[1] or M.shape[0] < 1:
            raise ValueError(f"ReferenceProblem: M must be a square matrix, got shape {M.shape}")
        if not np.array_equal(M, M.T):
            raise ValueError("ReferenceProblem: M must be symmetric")
        object.__setattr__(self, "M", M)

    @property
    def n(self) -> int:
        """Number of bodies."""
        return int(self.M.shape[0])

    @property
    def is_diagonal(self) -> bool:
        """True when every off-diagonal entry of M is exactly zero (explicit VI)."""
        return bool(np.count_nonzero(self.M - np.diag(np.diag(self.M))) == 0)


def problem_from_system(
    system: System,
    parameter_values: Sequence[float] | Mapping[str, float] | None = None,
) -> ReferenceProblem:
    """Numeric M, V and dV/dq of a `System` (sympy.diff + sympy.lambdify, NumPy module).

    `parameter_values` overrides the spec's values: a sequence in declared order, or a
    mapping from some parameter names to values.

    The general part `system.potential` is differentiated in the 3n global symbols (skipped
    when it is 0). Each structured term of `system.terms` is differentiated once in its own
    local symbols (q, or qi and qj) and evaluated vectorized over all its members, with
    per-body gradients accumulated by `numpy.bincount`; nothing is expanded per member, so
    large systems (e.g. all 205,761 pairs of 642 bodies) stay cheap.

    Example:
        >>> import sympy as sp
        >>> from s2gen.system import System
        >>> from s2gen.symbols import q_symbol
        >>> m, g = sp.symbols("m g", real=True)
        >>> s = System.create(name="p", n=1, parameters={"m": 2.0, "g": 10.0},
        ...                   inertia=sp.Matrix([[m]]), potential=-m * g * q_symbol(1, 2))
        >>> problem_from_system(s).grad(np.array([[0.0, 0.0, 1.0]])).tolist()
        [[0.0, 0.0, -20.0]]

        A pair term (a spring of stiffness k between neighbours, V = k/2 |qi - qj|^2):

        >>> from s2gen.system import Term
        >>> from s2gen.symbols import local_vector
        >>> qi, qj = sp.Matrix(local_vector("qi")), sp.Matrix(local_vector("qj"))
        >>> k = sp.Symbol("k", real=True)
        >>> spring = Term("pair", k / 2 * (qi - qj).dot(qi - qj), select="chain")
        >>> s = System.create(name="c", n=3, parameters={"k": 2.0}, inertia=sp.eye(3),
        ...                   potential=sp.Integer(0), terms=[spring])
        >>> p = problem_from_system(s)
        >>> q = np.eye(3)
        >>> p.potential(q), p.grad(q).tolist()
        (4.0, [[2.0, -2.0, 0.0], [-2.0, 4.0, -2.0], [0.0, -2.0, 2.0]])
    """
    system.refuse_driven("building the reference problem")
    values = _parameter_values(system, parameter_values)
    n = system.n
    ps = [sp.Symbol(p, real=True) for p in system.parameter_names]
    pvals = list(values)
    general = _general_part(system, ps, pvals)
    kernels = [_compile_term(t, n, ps, values) for t in system.terms if t.count(n) > 0]

    def potential(q: Array) -> float:
        qa = numbers(q)
        total = 0.0 if general is None else general[0](qa)
        if kernels:
            qT = np.ascontiguousarray(qa.reshape(n, 3).T)
            total += sum(k.potential(qT) for k in kernels)
        return scalar(total)  # type: ignore[no-any-return]

    def grad(q: Array) -> Array:
        qa = numbers(q)
        if not kernels:
            return np.zeros((n, 3)) if general is None else general[1](qa)
        qT = np.ascontiguousarray(qa.reshape(n, 3).T)
        kind = np.result_type(qT, *(np.asarray(k.params) for k in kernels))
        out = np.zeros((3, n), dtype=kind)
        for k in kernels:
            k.add_grad(qT, out)
        g = np.ascontiguousarray(out.T)
        return g if general is None else g + general[1](qa)

    return ReferenceProblem(M=inertia(system, values), grad=grad, potential=potential)


def inertia(system: System, values: Sequence[Any]) -> Array:
    """M at the parameter values: `System.inertia_numeric` for real values; for complex ones
    (a complex-step derivative in the parameters) each entry of the SymPy matrix evaluated by
    NumPy in complex arithmetic (small n: the matrix is dense).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> M = inertia(s, [v + 1e-30j for v in s.parameter_values])
        >>> bool(np.array_equal(M.real, s.inertia_numeric())), bool(np.any(M.imag != 0))
        (True, True)
    """
    if not np.iscomplexobj(np.asarray(values)):
        return system.inertia_numeric(values)
    matrix = sp.Matrix(system.inertia)
    entries = sp.lambdify(list(system.parameter_symbols), matrix, modules=MODULES)
    return np.asarray(entries(*values), dtype=complex).reshape(system.n, system.n)


def _parameter_values(
    system: System, parameter_values: Sequence[float] | Mapping[str, float] | None
) -> tuple[float, ...]:
    """The parameter values in declared order: the spec's, overridden as described in
    `problem_from_system`."""
    if parameter_values is None:
        return tuple(system.parameter_values)
    if isinstance(parameter_values, Mapping):
        unknown = set(parameter_values) - set(system.parameter_names)
        if unknown:
            raise ValueError(f"problem_from_system: unknown parameters {sorted(unknown)}")
        merged = {**system.parameters, **parameter_values}
        return tuple(scalar(merged[p]) for p in system.parameter_names)
    values = tuple(scalar(v) for v in parameter_values)
    if len(values) != len(system.parameter_names):
        raise ValueError(
            f"problem_from_system: expected {len(system.parameter_names)} parameter values, "
            f"got {len(values)}"
        )
    return values


def _general_part(
    system: System, ps: list[sp.Symbol], pvals: list[float]
) -> tuple[PotentialFn, GradFn] | None:
    """V and dV/dq of `system.potential` in the 3n global symbols, or None when it is 0."""
    V = sp.sympify(system.potential)
    if V == 0:
        return None
    n = system.n
    qs = q_symbols(n)
    v_fn = sp.lambdify([qs, ps], V, modules=MODULES, dummify=True)
    g_fn = sp.lambdify([qs, ps], [sp.diff(V, s) for s in qs], modules=MODULES, dummify=True)

    def potential(q: Array) -> float:
        return scalar(v_fn(list(numbers(q).ravel()), pvals))  # type: ignore[no-any-return]

    def grad(q: Array) -> Array:
        flat = g_fn(list(numbers(q).ravel()), pvals)
        return numbers(flat).reshape(n, 3)

    return potential, grad


def _term_indices(term: Term, n: int) -> tuple[Array, ...]:
    """0-based body index arrays of a term's members, one per role, in loop order (written
    here from the definition of each selection, independently of `s2gen.terms`)."""
    selection = term.selection
    if selection.listed:
        members = np.array(term.members, dtype=np.intp).reshape(len(term.members), -1)
        return tuple(np.ascontiguousarray(members[:, r]) for r in range(members.shape[1]))
    if selection is Selection.BODIES:
        return (np.arange(n, dtype=np.intp),)
    if selection is Selection.CHAIN:
        return np.arange(n - 1, dtype=np.intp), np.arange(1, n, dtype=np.intp)
    if selection is Selection.RING:
        i = np.arange(n, dtype=np.intp)
        return i, np.roll(i, -1)  # (1, 2), ..., (n - 1, n), (n, 1)
    if selection in (Selection.ALL_PAIRS, Selection.CUTOFF_PAIRS):
        i, j = np.triu_indices(n, k=1)  # row-major i < j
        return i.astype(np.intp), j.astype(np.intp)
    raise ValueError(f"{term.label}: the reference has no enumeration of {selection}")


@dataclass(frozen=True)
class _TermKernel:
    """One term compiled for vectorized evaluation over all of its members.

    `value` and `gradient` are lambdified functions of (local position components, data
    symbols, parameters), each argument a scalar or a (count,) array; `gradient` returns the
    derivatives in the local position symbols (3 per role).
    """

    n: int
    index: tuple[Array, ...]
    data: tuple[Array, ...]
    params: tuple[Any, ...]  # floats, or complex numbers for a complex-step derivative
    value: Callable[..., Any]
    gradient: Callable[..., Any]
    cutoff: float | None = None
    body: tuple[tuple[Array, int], ...] = ()  # per-body columns (n,) and the member's body

    def _active(self, qT: Array) -> tuple[Array, ...]:
        """The members' index arrays; with a cutoff, only the pairs closer than it (a plain
        vectorized distance test over all pairs)."""
        if self.cutoff is None:
            return self.index
        i, j = self.index
        d2 = sum((qT[c].take(i) - qT[c].take(j)) ** 2 for c in range(3))
        keep = d2 < self.cutoff**2
        return i[keep], j[keep]

    def _args(self, qT: Array, index: tuple[Array, ...]) -> list[Any]:
        """Arguments for `value`/`gradient` from qT (3, n): gathered position columns, data,
        per-body data gathered at the members' bodies, parameters."""
        cols = [qT[c].take(idx) for idx in index for c in range(3)]
        body = [column.take(index[r]) for column, r in self.body]
        return [*cols, *self.data, *body, *self.params]

    @staticmethod
    def _members(x: Any, count: int) -> Array:
        """A lambdified result (possibly a constant) as a (count,) float (or complex) array."""
        return np.broadcast_to(numbers(x), (count,))

    def potential(self, qT: Array) -> float:
        """Sum of the term over its members at positions qT (3, n)."""
        index = self._active(qT)
        values = self._members(self.value(*self._args(qT, index)), index[0].size)
        return scalar(np.sum(values))  # type: ignore[no-any-return]

    def add_grad(self, qT: Array, out: Array) -> None:
        """Add the term's gradient at positions qT (3, n) into out (3, n)."""
        index = self._active(qT)
        parts = self.gradient(*self._args(qT, index))
        for r, idx in enumerate(index):
            for c in range(3):
                weights = self._members(parts[3 * r + c], idx.size)
                out[c] += _scatter(idx, weights, self.n)


def _scatter(idx: Array, weights: Array, n: int) -> Array:
    """The sums of `weights` per index 0..n-1 (`numpy.bincount`, which takes real weights:
    a complex array is summed as its real and imaginary parts)."""
    if np.iscomplexobj(weights):
        real = np.bincount(idx, weights=weights.real, minlength=n)
        return real + 1j * np.bincount(idx, weights=weights.imag, minlength=n)
    return np.bincount(idx, weights=weights, minlength=n)


def _compile_term(term: Term, n: int, ps: list[sp.Symbol], values: Sequence[float]) -> _TermKernel:
    """Differentiate `term.expr` once in its local position symbols and lambdify value and
    gradient; gather index arrays and per-member data columns."""
    index = _term_indices(term, n)
    count = int(index[0].size)
    columns: list[Array] = []
    for d in term.data:
        table = np.array(d.values, dtype=float).reshape(count, d.width)
        columns.extend(np.ascontiguousarray(table[:, k]) for k in range(d.width))
    body: list[tuple[Array, int]] = []
    body_syms: list[sp.Symbol] = []
    for d, r, symbols in term.body_symbols():
        table = np.asarray(d.values, dtype=float).reshape(n, d.width)
        body.extend((np.ascontiguousarray(table[:, k]), r) for k in range(d.width))
        body_syms.extend(symbols)
    positions = list(term.position_symbols())
    data_syms = [*term.data_symbols(), *body_syms]
    # A datum shadows a parameter of the same name (as in Term.instance): give the parameter a
    # fresh placeholder so the argument list has no duplicate symbols.
    taken = set(data_syms) | set(positions)
    params = [sp.Dummy() if s in taken else s for s in ps]
    args = [*positions, *data_syms, *params]
    expr = sp.sympify(term.expr)
    derivatives = [sp.diff(expr, s) for s in positions]
    value = sp.lambdify(args, expr, modules=MODULES, dummify=True, cse=True)
    gradient = sp.lambdify(args, derivatives, modules=MODULES, dummify=True, cse=True)
    return _TermKernel(
        n=n,
        index=index,
        data=tuple(columns),
        params=tuple(scalar(v) for v in values),
        value=value,
        gradient=gradient,
        cutoff=term.cutoff,
        body=tuple(body),
    )
