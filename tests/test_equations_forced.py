"""The symbolic force terms (s2gen.equations.forced) against the driven reference, in values.

At random states the kernels and the forced equations, evaluated numerically, must reproduce
what the independent reference (s2gen.reference.forced*) computes, to 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from s2gen.equations.forced import (
    force_kernel,
    forced_el_residual,
    forced_kernels,
    forced_legendre_pair,
)
from s2gen.ir import KernelDef
from s2gen.reference import ReferenceProblem, inertia_operator
from s2gen.reference.forced import DrivenProblem, driven_rhs
from s2gen.reference.forced_steps import forced_vi_step
from s2gen.symbols import vector

RNG = np.random.default_rng(20)
E3 = np.array([0.0, 0.0, 1.0])


def evaluate(kernel: KernelDef, **values) -> dict[str, np.ndarray]:
    """The kernel's outputs at the given inputs (scalars or arrays, by input name)."""
    syms = [s for a in kernel.inputs for s in a.symbols]
    vals = [float(v) for a in kernel.inputs for v in np.ravel(values[a.name])]
    fn = sp.lambdify(syms, [list(o.exprs) for o in kernel.outputs], modules="numpy")
    return {o.name: np.array(r, dtype=float) for o, r in zip(kernel.outputs, fn(*vals))}


def kernel(name: str) -> KernelDef:
    return next(k for k in forced_kernels() if k.name == name)


def random_state(n: int) -> tuple[np.ndarray, np.ndarray]:
    q = RNG.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = RNG.normal(size=(n, 3))
    return q, w - np.sum(w * q, axis=1)[:, None] * q


def damped(M: np.ndarray, c: float = 0.7) -> DrivenProblem:
    """Gravity along e3, viscous damping -c qdot_i and a rotating force (cos 2t, sin 2t, 0) u0."""
    k = np.arange(1.0, M.shape[0] + 1)
    base = ReferenceProblem(M, lambda q: k[:, None] * E3 + 0 * q, lambda q: float(k @ q[:, 2]))

    def force(q, w, t, u):
        return -c * np.cross(w, q) + u[0] * np.array([np.cos(2 * t), np.sin(2 * t), 0.0])

    return DrivenProblem(base, force=force, n_inputs=1)


def force_jacobian_w(c: float, q: np.ndarray) -> np.ndarray:
    """d(-c w x q)/dw = c hat(q)."""
    return c * np.array([[0, -q[2], q[1]], [q[2], 0, -q[0]], [-q[1], q[0], 0]])


def test_forced_continuous_residual_vanishes_on_the_reference_field() -> None:
    M = np.array([[2.3, 0.6], [0.6, 1.1]])
    p, u, t = damped(M), np.array([0.9]), 0.37
    sym = {s: vector(s) for s in ("qi", "qj", "wi", "wj", "ai", "aj", "gi", "Fi")}
    mii, mij = sp.symbols("mii mij")
    R = forced_el_residual(mii, mij, *sym.values())
    fn = sp.lambdify([mii, mij, *[list(v) for v in sym.values()]], list(R), modules="numpy")
    for _ in range(5):
        q, w = random_state(2)
        _, wdot = driven_rhs(p, t, q, w, u)
        g, F = p.dVdq(q, t, u), p.F(q, w, t, u)
        for i, j in ((0, 1), (1, 0)):
            r = fn(M[i, i], M[i, j], q[i], q[j], w[i], w[j], wdot[i], wdot[j], g[i], F[i])
            assert np.max(np.abs(r)) < 1e-12


def test_frhs_body_is_the_change_of_the_field_the_force_makes() -> None:
    M = np.array([[2.3, 0.6], [0.6, 1.1]])
    p, u, t = damped(M), np.array([0.9]), 1.1
    for _ in range(5):
        q, w = random_state(2)
        _, with_force = driven_rhs(p, t, q, w, u)
        _, without = driven_rhs(DrivenProblem(p.base), t, q, w, [])
        F = p.F(q, w, t, u)
        b = np.array([evaluate(kernel("frhs_body"), q=q[i], F=F[i])["b"] for i in range(2)])
        change = inertia_operator(M, q) @ (with_force - without).ravel()
        assert np.max(np.abs(change - b.ravel())) < 1e-12


def test_forced_explicit_vi_kernels_reproduce_the_reference_step() -> None:
    """Diagonal M: fvi_pos gives q+, and Newton on fvi_vel (its own Jacobian) gives omega+."""
    m, c, h = 1.7, 0.7, 0.05
    p = damped(np.array([[m]]), c)
    u = np.array([1.3])
    for _ in range(5):
        q, w = random_state(1)
        t = float(RNG.uniform(0, 3))
        q1, w1, _ = forced_vi_step(p, q, w, t, h, u)
        pos = evaluate(
            kernel("fvi_pos"), h=h, m=m, q=q[0], w=w[0], g=p.dVdq(q, t, u)[0], F=p.F(q, w, t, u)[0]
        )
        assert np.max(np.abs(pos["qn"] - q1[0])) < 1e-12
        gn = p.dVdq(q1, t + h, u)[0]
        wn = pos["wh"].copy()
        for _ in range(3):
            Fn = p.F(q1, wn[None, :], t + h, u)[0]
            vel = evaluate(
                kernel("fvi_vel"),
                h=h,
                m=m,
                wh=pos["wh"],
                wn=wn,
                qn=q1[0],
                gn=gn,
                Fn=Fn,
                Fw=force_jacobian_w(c, q1[0]),
            )
            wn = wn - np.linalg.solve(vel["jac"].reshape(3, 3), vel["r"])
        assert np.max(np.abs(wn - w1[0])) < 1e-12


def test_forced_legendre_transforms_hold_at_the_reference_coupled_step() -> None:
    """q_i x sum_j M_ij qdot_j equals minus_D1 at the start and D2 at the end of a reference
    step (Newton on the Cayley parameters), for both bodies of a coupled pair."""
    M = np.array([[2.3, 0.6], [0.6, 1.1]])
    p, u, h = damped(M), np.array([0.8]), 0.04
    lp = forced_legendre_pair()
    names = ("qi", "qj", "qni", "qnj", "gi", "gj", "gni", "gnj", "Fi", "Fni")
    args = [sp.Symbol("m", positive=True), sp.Symbol("mjj", positive=True)]
    args += [sp.Symbol("mij", real=True), sp.Symbol("h", positive=True)]
    fns = {
        key: sp.lambdify([*args, *[list(vector(s)) for s in names]], list(lp[key]), "numpy")
        for key in ("minus_D1", "D2")
    }
    for _ in range(4):
        q, w = random_state(2)
        t = float(RNG.uniform(0, 3))
        q1, w1, its = forced_vi_step(p, q, w, t, h, u)
        assert its > 0
        g, g1 = p.dVdq(q, t, u), p.dVdq(q1, t + h, u)
        F, F1 = p.F(q, w, t, u), p.F(q1, w1, t + h, u)
        mom0 = np.cross(q, M @ np.cross(w, q))
        mom1 = np.cross(q1, M @ np.cross(w1, q1))
        for i, j in ((0, 1), (1, 0)):
            vals = (q[i], q[j], q1[i], q1[j], g[i], g[j], g1[i], g1[j], F[i], F1[i])
            mats = (M[i, i], M[j, j], M[i, j], h)
            assert np.max(np.abs(fns["minus_D1"](*mats, *vals) - mom0[i])) < 1e-12
            assert np.max(np.abs(fns["D2"](*mats, *vals) - mom1[i])) < 1e-12


def test_fd_and_fc_body_are_the_force_parts_of_the_transforms() -> None:
    q, w = random_state(1)
    F, Fn, h = RNG.normal(size=3), RNG.normal(size=3), 0.03
    fd = evaluate(kernel("fd_body"), h=h, q=q[0], F=F)["d"]
    assert np.max(np.abs(fd - 0.5 * h * h * np.cross(q[0], F))) < 1e-15
    Fw = RNG.normal(size=(3, 3))
    fc = evaluate(kernel("fc_body"), h=h, qn=q[0], Fn=Fn, Fw=Fw)
    assert np.max(np.abs(fc["c"] - 0.5 * h * np.cross(q[0], Fn))) < 1e-15
    # the Jacobian against central differences of the force part in omega+ for F = Fw omega
    num = np.column_stack(
        [
            (0.5 * h * np.cross(q[0], Fw @ (w[0] + e)) - 0.5 * h * np.cross(q[0], Fw @ (w[0] - e)))
            / 2e-6
            for e in 1e-6 * np.eye(3)
        ]
    )
    assert np.max(np.abs(fc["jac"].reshape(3, 3) - num)) < 1e-9


def test_force_kernel_values_and_jacobian_match_the_expression() -> None:
    q, w = vector("q"), vector("w")
    c, t = sp.Symbol("c", positive=True), sp.Symbol("t", real=True)
    expr = -c * w.cross(q) * (1 + sp.sin(t) * w.dot(w)) + sp.Matrix([sp.cos(t), 0, 1])
    k = force_kernel("drag", expr, q, w)
    qv, wv = random_state(1)
    out = evaluate(k, c=0.4, t=0.3, q=qv[0], w=wv[0])

    def F(wx: np.ndarray) -> np.ndarray:
        return -0.4 * np.cross(wx, qv[0]) * (1 + np.sin(0.3) * wx @ wx) + [np.cos(0.3), 0, 1]

    assert np.max(np.abs(out["F"] - F(wv[0]))) < 1e-14
    num = np.column_stack([(F(wv[0] + e) - F(wv[0] - e)) / 2e-6 for e in 1e-6 * np.eye(3)])
    assert np.max(np.abs(out["Fw"].reshape(3, 3) - num)) < 1e-8
    with pytest.raises(ValueError, match="a force is a 3-vector"):
        force_kernel("bad", sp.Matrix([1, 2]), q, w)
