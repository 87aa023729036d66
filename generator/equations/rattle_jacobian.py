"""The exact Jacobian of one RATTLE step, by the implicit function theorem.

Input: a `System` with step Jacobians (`has_rattle_jacobian`), any M. Output: the
kernels of the derivatives of the equations one RATTLE step of size h from (x, v) (positions
on |x_i| = 1 and velocities v_i = xdot_i) to (x+, v+) solves, E(y; x, v, p) = 0, in its
unknowns y, in (x, v), in g = dV/dq at x and g+ at x+ (held) and in M. The ``jacobian`` part
assembles them at run time, multiplies the ones in g and g+ into the Hessian of V at x and x+
(and dg/dp), solves dy/d(x, v, p) = -E_y^-1 E_(x,v,p), whose rows of (x+, v+) are the
substep's derivative, multiplies a composition's substeps' (rattle4, rattle6, rattle8) and
maps the state (q, w) in and out of (x, v) as the step does (x = q, v = w x q at the start,
w+ = x+ x v+ at the end).

A driven system's RATTLE (`s2gen.reference.forced_steps`) solves the same equations with g
replaced by G = g - F(x, w, t, u) at the start and g+ by g+ - F+, F+ = F(x+, w+, t + h, u),
w+ = x+ x v+ (implicit when F reads w); E being linear in g and g+, the kernels are the same
and the driven step's Jacobian chains them with the forces' derivatives (dF+/dv+ through
w+), each substep mapped in and out of (x, v) as the driven step maps it.

The equations are the constrained Stormer-Verlet step the emitted RATTLE solves (in closed form
for a diagonal M, by Newton on the multipliers otherwise, `s2gen.equations.rattle`), with the
unknowns y = (v+1/2, lambda, x+, v+, mu), 11 per body:

    M (v+1/2 - v) + h/2 (g + lambda x) = 0,    |x_i+|^2 - 1 = 0,    x+ - x - h v+1/2 = 0,
    M (v+ - v+1/2) + h/2 (g+ + mu x+) = 0,     x_i+ . v_i+ = 0,

M acting body by body (M_ij times the 3-vector of body j), lambda x the vector of the bodies'
lambda_i x_i. E is a sum of one-body parts (``rattle_jacobian``, M_ii's terms with the rest of
the body's rows) and pair parts (``rattle_jacobian_pair``, M_ij's), each differentiated once
by SymPy for a generic body and pair; the multipliers are recovered from the converged step
(lambda_i from the first row of body i, mu_i from the fourth), so the step itself is not
changed.

Example:
    >>> from s2gen.systems import builtin
    >>> [k.name for k in rattle_jacobian_kernels(builtin("double_pendulum").with_jacobians())]
    ['rattle_jacobian', 'rattle_jacobian_pair']
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.hessian import sparse_jacobian
from s2gen.equations.jacobian import has_jacobian
from s2gen.ir import Argument, KernelDef, Output
from s2gen.system import System

__all__ = ["RATTLE_BODY", "has_rattle_jacobian", "rattle_jacobian_kernels"]

#: A body's vectors in the generic body's equations: the unknowns, then the state and the
#: gradients (E is linear in g and g+, which the kernel does not take)
RATTLE_BODY = ("vh", "xn", "vn", "x", "v", "g", "gn")


def has_rattle_jacobian(system: System) -> bool:
    """Whether the emitted step_jacobian() differentiates the RATTLE family: a system with
    step Jacobians whose module integrates with it (a driven one: without forces, or with a
    diagonal M, `s2gen.methods.driven_methods`).

    Example:
        >>> from s2gen.systems import builtin
        >>> has_rattle_jacobian(builtin("double_pendulum").with_jacobians())
        True
    """
    return has_jacobian(system) and not (system.driven and system.forces and not system.is_diagonal)


def _vec(name: str) -> sp.Matrix:
    return sp.Matrix(sp.symbols(f"{name}_0:3", real=True))


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def rattle_jacobian_kernels(system: System) -> list[KernelDef]:
    """``rattle_jacobian`` (the generic body: its 11 rows of E differentiated in its vectors
    (11 x 3 each, row-major: r_<name>), its multipliers (r_lam, r_mu: 11) and M_ii (r_m: 11))
    and ``rattle_jacobian_pair`` (the generic pair i < j: rows of body i, then j, 22, in
    v+1/2, v+ and v of both bodies (p_<name><i or j>, 22 x 3) and in M_ij (p_m: 22)); none
    without `has_rattle_jacobian`."""
    if not has_rattle_jacobian(system):
        return []
    h, m, mij = sp.Symbol("h", positive=True), sp.Symbol("m", positive=True), sp.Symbol("mij")
    lam, mu = sp.Symbol("lam", real=True), sp.Symbol("mu", real=True)
    b = {name: _vec(name) for name in RATTLE_BODY}
    r1 = m * (b["vh"] - b["v"]) + h / 2 * (b["g"] + lam * b["x"])
    r2 = b["xn"].dot(b["xn"]) - 1
    r3 = b["xn"] - b["x"] - h * b["vh"]
    r4 = m * (b["vn"] - b["vh"]) + h / 2 * (b["gn"] + mu * b["xn"])
    r5 = b["xn"].dot(b["vn"])
    rows = [*r1, r2, *r3, *r4, r5]
    body = KernelDef(
        "rattle_jacobian",
        "one body's rows of the RATTLE step's equations (11: velocity at the half step, "
        "constraint, position, end velocity, tangency) differentiated in its vectors, "
        "multipliers and M_ii (row-major)",
        (
            Argument("h", (h,), scalar=True),
            Argument("m", (m,), scalar=True),
            Argument("lam", (lam,), scalar=True),
            Argument("mu", (mu,), scalar=True),
            *(Argument(name, tuple(b[name])) for name in RATTLE_BODY if name not in ("g", "gn")),
        ),
        (
            *(Output(f"r_{n}", _flat(sparse_jacobian(rows, list(b[n])))) for n in RATTLE_BODY),
            Output("r_lam", tuple(sp.diff(e, lam) for e in rows)),
            Output("r_mu", tuple(sp.diff(e, mu) for e in rows)),
            Output("r_m", tuple(sp.diff(e, m) for e in rows)),
        ),
    )
    pv = {f"{n}{k}": _vec(f"{n}{k}") for n in ("vh", "vn", "v") for k in "ij"}
    zero3, zero1 = sp.zeros(3, 1), sp.zeros(1, 1)

    def part(j: str) -> list[sp.Expr]:
        """The rows of the body the pair couples to body j."""
        a = mij * (pv[f"vh{j}"] - pv[f"v{j}"])
        c = mij * (pv[f"vn{j}"] - pv[f"vh{j}"])
        return [*a, *zero1, *zero3, *c, *zero1]

    prow = part("j") + part("i")
    names = [f"{n}{k}" for n in ("vh", "vn", "v") for k in "ij"]
    pair = KernelDef(
        "rattle_jacobian_pair",
        "one coupled pair's part of the RATTLE step's equations (22 rows: body i's, then j's) "
        "differentiated in both bodies' velocities and in M_ij (row-major)",
        (Argument("mij", (mij,), scalar=True), *(Argument(n, tuple(pv[n])) for n in names)),
        (
            *(Output(f"p_{n}", _flat(sparse_jacobian(prow, list(pv[n])))) for n in names),
            Output("p_m", tuple(sp.diff(e, mij) for e in prow)),
        ),
    )
    return [body, pair]
