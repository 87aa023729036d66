"""Rows loops split at their calls (`s2gen.passes.fission`): the analysis keeps the calls out of
the vectorised loops, stores only what is costly to recompute, and the split emitted C agrees
with the reference (gradient, w' = -q x g, and a VI trajectory) and with finite differences of
the potential written out here pair by pair."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

import s2gen
from s2gen.ir import Argument, KernelDef, Output
from s2gen.passes import lower, lower_system
from s2gen.passes.fission import split_at_calls
from s2gen.passes.layout import STACK_BYTES, layout_pass
from s2gen.runtime import get_backend, simulate
from s2gen.spec import define_system

N = 9
RNG = np.random.default_rng(11)
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.5, size=(N, 3)))
CHARGE = RNG.uniform(0.5, 1.5, N).round(6)
SIZE = RNG.uniform(0.2, 0.4, N).round(6)
K, B = 1.7, 0.3
#: its gradient calls exp of two call-free arguments (split at) and cos of a call's value (not
#: split at: it stays in the last loop); the log's derivative is a division
V = "k*ci*cj*exp(-k*norm(qi - qj))/norm(qi - qj) + b*log(si + sj + norm(qi - qj)**2)"
V_NESTED = " + b*sin(exp(-norm(qi - qj)))"


def _system(name: str, nested: bool = True) -> Any:
    return define_system(
        name=name,
        bodies=N,
        parameters={"k": K, "b": B},
        diagonal="1 + i/10",
        data={"c": CHARGE.tolist(), "s": SIZE.tolist()},
        pair_terms=[{"V": V + (V_NESTED if nested else ""), "pairs": "all"}],
        initial_q=Q0,
        initial_omega=W0,
    )


def _potential(q: np.ndarray) -> float:
    """The system's potential written out pair by pair."""
    total = 0.0
    for i in range(N):
        for j in range(i + 1, N):
            r = float(np.linalg.norm(q[i] - q[j]))
            total += K * CHARGE[i] * CHARGE[j] * np.exp(-K * r) / r
            total += B * np.log(SIZE[i] + SIZE[j] + r * r) + B * np.sin(np.exp(-r))
    return total


def test_split_keeps_calls_out_of_the_vectorised_loops() -> None:
    qi, qj = sp.symbols("qi_0:3", real=True), sp.symbols("qj_0:3", real=True)
    d = sp.sqrt(sum((a - b) ** 2 for a, b in zip(qi, qj, strict=True)))
    args = (Argument("qi", qi), Argument("qj", qj))
    k = lower(KernelDef("k", "", args, (Output("gi", (sp.exp(-d) / d + sp.exp(sp.exp(d)),)),)))
    split = split_at_calls(k)
    assert split is not None
    # exp(-d) and the inner exp(d) are split at; the outer exp reads a call's value and stays
    assert [str(c) for c in split.calls if c is not None] == ["exp(fission_arg)"] * 2
    first = [a.expr for a in split.first]
    assert not any(e.atoms(sp.Function) for e in first)
    assert (
        sum(isinstance(e, sp.exp) for a in split.last for e in sp.preorder_traversal(a.expr)) == 1
    )
    # the square root is stored, not recomputed in the last loop; the differences are recomputed
    roots = [p for a in split.last for p in a.expr.atoms(sp.Pow) if p.exp == sp.Rational(1, 2)]
    assert not roots
    assert len(split.stores) == 3  # the square root and the two calls' arguments
    plain = lower(KernelDef("k", "", args, (Output("gi", (1 / d,)),)))
    assert split_at_calls(plain) is None


def test_layout_splits_within_the_stack_budget() -> None:
    module = lower_system(_system("fission_budget"))
    assert module.terms[0].rows and module.terms[0].fission is not None
    stores = len(module.terms[0].fission.stores)
    # r, 1/r and 2/(si + sj + r^2) (costly to recompute), the arguments of exp(-k r), exp(-r)
    assert stores == 5
    big = layout_pass(replace(module, n=STACK_BYTES // (8 * stores) + 1))
    assert big.terms[0].rows and big.terms[0].fission is None


def test_split_rows_in_c_agree_with_reference_and_finite_differences(tmp_path: Path) -> None:
    system = _system("fission_agree")
    p = np.array(system.parameter_values)
    q = system.q0
    s2gen.generate(system, "c", out=tmp_path)
    source = (tmp_path / "fission_agree.c").read_text(encoding="utf-8")
    assert "rb3[j] = exp(rb3[j]);" in source and "rb4[j] = exp(rb4[j]);" in source
    g_ref = get_backend(system, "reference")._problem(p).grad(q)
    c = get_backend(system, "c")
    _, dw = c.rhs(q, np.zeros_like(q), p)  # with a workspace: the split rows loop
    scale = float(np.max(np.abs(g_ref)))
    mass = 1 + np.arange(1, N + 1)[:, None] / 10  # the diagonal inertia 1 + i/10
    assert np.max(np.abs(mass * dw + np.cross(q, g_ref))) < 1e-12 * scale
    assert np.max(np.abs(c.gradient(q, p) - g_ref)) < 1e-12 * scale
    assert np.max(np.abs(get_backend(system, "numpy").gradient(q, p) - g_ref)) < 1e-12 * scale
    # central differences of the potential written out here (error ~ eps^2 |V'''|)
    eps = 1e-5
    fd = np.zeros_like(q)
    for b in range(N):
        for c3 in range(3):
            up, down = q.copy(), q.copy()
            up[b, c3] += eps
            down[b, c3] -= eps
            fd[b, c3] = (_potential(up) - _potential(down)) / (2 * eps)
    assert np.max(np.abs(fd - g_ref)) < 1e-6 * scale
    truth = simulate(system, "vi", "reference", h=0.01, T=0.5, energy=False)
    for backend in ("c", "numpy"):
        run = simulate(system, "vi", backend, h=0.01, T=0.5, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-12, backend
