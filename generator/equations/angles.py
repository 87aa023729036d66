"""The classical spherical-angle form of a system on (S^2)^n, for comparison with the S^2 form.

Input: a `System` (inertia M, potential V). Output: SymPy equations M(x) xdd = F(x, xd) in the
angles x = (theta_1, phi_1, ..., theta_n, phi_n), where body i's unit vector is
q_i = (sin theta_i cos phi_i, sin theta_i sin phi_i, cos theta_i), and their `KernelDef`s. The
emitted modules and their runner are in `s2gen.runtime.angles`.

Derivation: L = 1/2 sum_ij M_ij qdot_i . qdot_j - V(q(x)) with qdot_i = J_i(x_i) xd_i; the mass
matrix is the Hessian of L in xd and F_a = dL/dx_a - sum_k (d^2 L / dxd_a dx_k) xd_k. With
`simplify=True` every entry is passed through `sympy.simplify` (the textbook route: fewer
operations, much longer derivation).

The chart is singular where sin theta_i = 0 (q_i = +-e3): there phi_i is arbitrary, phi_i-dot
undefined and M(x) singular; `POLE_TOL` and `MIN_PIVOT_RATIO` are the thresholds the emitted
code uses to report it.

Example:
    >>> from s2gen.systems import builtin
    >>> eq = derive_angles(builtin("double_pendulum"))
    >>> eq.mass.shape, len(eq.force)
    ((4, 4), 4)
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import sympy as sp

from s2gen.ir import Argument, KernelDef, Output
from s2gen.methods import ANGLE_METHODS  # the integrators of the angle modules (re-exported)
from s2gen.symbols import q_symbol
from s2gen.system import SpecError, System

__all__ = [
    "ANGLE_METHODS",
    "MIN_PIVOT_RATIO",
    "POLE_TOL",
    "AngleEquations",
    "angle_kernels",
    "angle_symbols",
    "derive_angles",
    "sphere_point",
]

#: M(x) counts as singular when min |pivot| <= MIN_PIVOT_RATIO * max |pivot| in its LU factors.
MIN_PIVOT_RATIO = 64 * float(np.finfo(float).eps)
#: An initial q_i with sin theta_i below this is "at a pole" (phi_i-dot would be meaningless).
POLE_TOL = float(np.sqrt(MIN_PIVOT_RATIO))


# ----------------------------------------------------------------------------------- derivation
def angle_symbols(n: int) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...]]:
    """(x, xd): th1, ph1, ..., thn, phn and their rates thd1, phd1, ... (body-major).

    Example:
        >>> angle_symbols(1)
        ((th1, ph1), (thd1, phd1))
    """
    x = tuple(sp.Symbol(f"{a}{i}", real=True) for i in range(1, n + 1) for a in ("th", "ph"))
    xd = tuple(sp.Symbol(f"{a}d{i}", real=True) for i in range(1, n + 1) for a in ("th", "ph"))
    return x, xd


def sphere_point(theta: sp.Expr, phi: sp.Expr) -> sp.Matrix:
    """q(theta, phi) = (sin theta cos phi, sin theta sin phi, cos theta).

    Example:
        >>> sphere_point(sp.pi / 2, 0).T
        Matrix([[1, 0, 0]])
    """
    return sp.Matrix([sp.sin(theta) * sp.cos(phi), sp.sin(theta) * sp.sin(phi), sp.cos(theta)])


@dataclass(frozen=True)
class AngleEquations:
    """M(x) xdd = F(x, xd) of one system in angles, with the energy and the derivation time."""

    system: System
    x: tuple[sp.Symbol, ...]
    xd: tuple[sp.Symbol, ...]
    mass: sp.ImmutableMatrix
    force: tuple[sp.Expr, ...]
    energy: sp.Expr
    simplified: bool
    seconds: float


def _check_symbols(system: System) -> None:
    """Angle symbols must not collide with parameter names; cutoff terms are not supported."""
    x, xd = angle_symbols(system.n)
    clash = sorted({s.name for s in x + xd} & set(system.parameter_names))
    if clash:
        raise SpecError(f"{system.origin}: parameter {clash[0]!r} clashes with an angle symbol")
    if any(getattr(t, "cutoff", None) is not None for t in system.terms):
        raise SpecError(f"{system.origin}: the angle form does not support pair-term cutoffs")


def derive_angles(system: System, simplify: bool = False) -> AngleEquations:
    """Euler-Lagrange equations of `system` in spherical angles (SymPy).

    Example:
        >>> from s2gen.spec import define_system
        >>> s = define_system(name="p", bodies=1, parameters={"m": 1.0, "g": 2.0},
        ...                   inertia=[["m"]], potential="-m*g*q1[2]")
        >>> eq = derive_angles(s)
        >>> sp.simplify(eq.mass)
        Matrix([
        [m,             0],
        [0, m*sin(th1)**2]])
    """
    _check_symbols(system)
    start = time.perf_counter()
    n = system.n
    x, xd = angle_symbols(n)
    qs = [sphere_point(x[2 * i], x[2 * i + 1]) for i in range(n)]
    qd = [
        q.diff(x[2 * i]) * xd[2 * i] + q.diff(x[2 * i + 1]) * xd[2 * i + 1]
        for i, q in enumerate(qs)
    ]
    M = system.inertia
    kinetic = sp.Rational(1, 2) * sum(
        (M[i, j] * qd[i].dot(qd[j]) for i in range(n) for j in range(n) if M[i, j] != 0),
        sp.Integer(0),
    )
    on_sphere = {q_symbol(i + 1, c): qs[i][c] for i in range(n) for c in range(3)}
    potential = system.full_potential().xreplace(on_sphere)
    lagrangian = kinetic - potential
    momenta = [sp.diff(lagrangian, v) for v in xd]
    dim = 2 * n
    upper = {(a, b): sp.diff(momenta[a], xd[b]) for a in range(dim) for b in range(a, dim)}
    force = [
        sp.diff(lagrangian, x[a]) - sum(sp.diff(momenta[a], x[k]) * xd[k] for k in range(dim))
        for a in range(dim)
    ]
    if simplify:
        upper = {key: sp.simplify(e) for key, e in upper.items()}
        force = [sp.simplify(e) for e in force]
    mass = sp.ImmutableMatrix(dim, dim, lambda a, b: upper[(min(a, b), max(a, b))])
    return AngleEquations(
        system=system,
        x=x,
        xd=xd,
        mass=mass,
        force=tuple(force),
        energy=kinetic + potential,
        simplified=simplify,
        seconds=time.perf_counter() - start,
    )


def angle_kernels(eq: AngleEquations) -> tuple[list[KernelDef], list[KernelDef]]:
    """(system kernels, per-body kernels): dynamics and energy; the map to (q, omega).

    Example:
        >>> from s2gen.systems import builtin
        >>> sk, bk = angle_kernels(derive_angles(builtin("double_pendulum")))
        >>> [k.name for k in sk], [k.name for k in bk]
        (['dynamics', 'energy'], ['to_sphere'])
    """
    p = Argument("p", eq.system.parameter_symbols)
    x, xd = Argument("x", eq.x), Argument("xd", eq.xd)
    dim = len(eq.x)
    dynamics = KernelDef(
        "dynamics",
        f"mass matrix M(x) (row-major {dim} x {dim}) and force F(x, xd) of M xdd = F",
        (p, x, xd),
        (Output("m", tuple(eq.mass)), Output("f", eq.force)),
        system=True,
    )
    energy = KernelDef(
        "energy",
        "total energy T + V in angles",
        (p, x, xd),
        (Output("e", (eq.energy,), True),),
        system=True,
    )
    th, ph, thd, phd = sp.symbols("theta phi thetad phid", real=True)
    q = sphere_point(th, ph)
    qdot = q.diff(th) * thd + q.diff(ph) * phd
    to_sphere = KernelDef(
        "to_sphere",
        "one body: q = q(theta, phi), omega = q x qdot",
        (Argument("a", (th, ph)), Argument("ad", (thd, phd))),
        (Output("q", tuple(q)), Output("w", tuple(q.cross(qdot)))),
    )
    return [dynamics, energy], [to_sphere]
