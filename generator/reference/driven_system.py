"""A driven `System` in numbers: the `DrivenProblem` of its spec, for the reference integrator.

Input: a `System` with forces, inputs or a time-dependent potential (small n: the potential
is expanded over its terms' members, `System.full_potential`, and the forces summed per body,
`System.force_vectors`), optionally parameter values.
Output: a `DrivenProblem` whose conservative base has M and no potential, and whose added
potential V(q, t, u), dV/dq, dV/dt and forces F(q, w, t, u) are SymPy's derivatives of the
spec's expressions turned into NumPy functions (`sympy.lambdify`); u is the inputs in the
spec's order. `integrate_driven` then integrates it by the reference's own equations.

Example:
    >>> from s2gen.spec import define_system
    >>> s = define_system(name="spin", bodies=1, parameters={"c": 0.5}, inputs={"tau": 1.0},
    ...                   diagonal=["2"], potential=0,
    ...                   forces={"F1": "tau*cross(e3, q1) - c*cross(w1, q1)"})
    >>> p = driven_problem_from_system(s)
    >>> q, w = np.array([[1.0, 0, 0]]), np.array([[0, 0, 2.0]])
    >>> p.F(q, w, 0.0, np.array([3.0])).tolist(), p.implicit_velocity
    ([[0.0, 2.0, 0.0]], True)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp

from s2gen.reference.forced import DrivenProblem
from s2gen.reference.problem import (
    MODULES,
    Array,
    ReferenceProblem,
    _parameter_values,
    inertia,
    numbers,
    scalar,
)
from s2gen.symbols import TIME, q_symbols, w_symbol
from s2gen.system import System

__all__ = ["driven_problem_from_system"]


def driven_problem_from_system(
    system: System,
    parameter_values: Sequence[float] | Mapping[str, float] | None = None,
) -> DrivenProblem:
    """The `DrivenProblem` of `system` (any system: a closed one gives a problem without
    drive). `parameter_values` overrides the spec's values as in `problem_from_system`."""
    values = _parameter_values(system, parameter_values)
    n = system.n
    pv: list[Any] = []  # the parameters' values when they stay symbols (complex values)
    if np.iscomplexobj(np.asarray(values)):
        # a complex-step derivative: SymPy would evaluate |p| of a complex number p as its
        # modulus, so the parameters stay symbols (fresh ones: a parameter may be called t)
        dummies = [sp.Dummy() for _ in values]
        subs: dict[sp.Symbol, Any] = dict(zip(system.parameter_symbols, dummies))
        pv = [list(values)]
    else:
        subs = dict(zip(system.parameter_symbols, values))
    extra = [list(subs.values())] if pv else []
    qs = q_symbols(n)
    ws = [w_symbol(i, c) for i in range(1, n + 1) for c in range(3)]
    us = list(system.inputs.symbols)
    zero = ReferenceProblem(inertia(system, values), lambda q: np.zeros((n, 3)), lambda q: 0.0)
    V = sp.sympify(system.full_potential()).xreplace(subs)  # a parameter t is substituted
    args = [qs, TIME, us, *extra]
    v_fn = sp.lambdify(args, V, modules=MODULES, dummify=True)
    g_fn = sp.lambdify(args, [sp.diff(V, s) for s in qs], modules=MODULES, dummify=True)
    t_fn = sp.lambdify(args, sp.diff(V, TIME), modules=MODULES, dummify=True)

    def flat(q: Array) -> list[float]:
        return list(numbers(q).ravel())

    def potential(q: Array, t: float, u: Array) -> float:
        return scalar(v_fn(flat(q), t, list(u), *pv))  # type: ignore[no-any-return]

    def grad(q: Array, t: float, u: Array) -> Array:
        return np.array(numbers(g_fn(flat(q), t, list(u), *pv))).reshape(n, 3)

    def potential_t(q: Array, t: float, u: Array) -> float:
        return scalar(t_fn(flat(q), t, list(u), *pv))  # type: ignore[no-any-return]

    force = None
    moving = False
    if system.forces:
        total = [sp.zeros(3, 1) for _ in range(n)]
        for f in system.forces:
            for body, force in f.total(n):
                total[body] += force
        F = [e.xreplace(subs) for v in total for e in v]
        moving = any(e.has(*ws) for e in F)
        f_fn = sp.lambdify([qs, ws, TIME, us, *extra], F, modules=MODULES, dummify=True)

        def force(q: Array, w: Array, t: float, u: Array) -> Array:
            out = f_fn(flat(q), flat(w), t, list(u), *pv)
            return np.array(numbers(out)).reshape(n, 3)

    return DrivenProblem(
        zero,
        potential=potential,
        grad=grad,
        potential_t=potential_t,
        force=force,
        velocity_dependent=moving,
        n_inputs=len(us),
    )
