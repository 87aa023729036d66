"""The lowering passes: each one's effect on the kernels, and that the motion does not change.

One system exercises every optional pass: six bodies with different masses (`reciprocal`), a
Lennard-Jones term over all pairs (`layout`'s rows, `hoist`'s parameter powers, `strength`'s
shared division), a bilinear term over a list of all pairs with per-pair coefficients
(`quadratic`'s matrix K: gathered from a list, its loop costs more than K), and a body term
with a half-integer power (`strength`'s square root, `powers`). For each pass the emitted C is
built without it and with the whole pipeline: both must follow the independent reference
integrator (1e-10), and the pass must show its effect on the kernels it rewrites.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.equations.assemble import sphere_module
from s2gen.ir import Kernel, Module
from s2gen.passes import PIPELINE, lower_module
from s2gen.passes.opcount import Ops, kernel_profile, profile
from s2gen.printing import print_module
from s2gen.render import render
from s2gen.runtime import Options, simulate
from s2gen.runtime.c import CBackend
from s2gen.spec import define_system
from s2gen.system import System

N = 6
STEPS = 200
OPTIONAL = ("quadratic", "reciprocal", "factor", "hoist", "strength", "powers", "layout")


@functools.lru_cache(maxsize=1)
def passes_system() -> System:
    rng = np.random.default_rng(3)
    q = rng.normal(size=(N, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = 0.3 * rng.normal(size=(N, 3))
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    masses = {f"m{i + 1}": 1.0 + 0.1 * i for i in range(N)}
    lj = "4*eps*((sigma**2/dot(qi-qj, qi-qj))**6 - (sigma**2/dot(qi-qj, qi-qj))**3)"
    pairs = [[i + 1, j + 1] for i in range(N) for j in range(i + 1, N)]
    coupling = {
        "V": "k*(a*dot(qi, qj) + b*(qi[0]*qj[1] + qi[1]*qj[0]))",
        "pairs": pairs,
        "data": {
            "a": rng.uniform(0.5, 1.5, len(pairs)).tolist(),
            "b": rng.uniform(-1, 1, len(pairs)).tolist(),
        },
    }
    return define_system(
        name="passes",
        bodies=N,
        parameters={"eps": 0.01, "sigma": 0.5, "k": 0.2, "c": 0.3, **masses},
        diagonal=list(masses),
        pair_terms=[{"V": lj, "pairs": "all"}, coupling],
        body_terms=[{"V": "c*(2 + q[2])**(3/2)", "bodies": "all"}],
        initial_q=q.tolist(),
        initial_omega=w.tolist(),
        run={"h": 0.01, "T": 1.0},
    )


@functools.cache
def lowered(without: str = "") -> Module:
    pipeline = tuple(p for p in PIPELINE if p[0] != without)
    return lower_module(sphere_module(passes_system()), pipeline)


def _kernel(module: Module, name: str) -> Kernel:
    k = module.kernel(name)
    assert isinstance(k, Kernel)
    return k


def _run(files: dict[str, str] | None, method: str) -> tuple[np.ndarray, np.ndarray]:
    system = passes_system()
    backend = CBackend(system, files)
    status, q, w, _, _ = backend.integrate(
        method,
        0.01,
        STEPS,
        np.array(system.q0, dtype=float),
        np.array(system.omega0, dtype=float),
        backend.default_params(),
        Options(),
        with_energy=False,
    )
    assert status == 0
    return q, w


@functools.cache
def _reference(method: str) -> tuple[np.ndarray, np.ndarray]:
    tr = simulate(passes_system(), method, "reference", h=0.01, T=STEPS * 0.01)
    return tr.q, tr.omega


@pytest.mark.parametrize("name", OPTIONAL)
def test_the_motion_does_not_depend_on_the_pass(name: str) -> None:
    """Without the pass, and with the whole pipeline, the emitted C follows the reference
    (VI and RK4, 200 steps) to 1e-10, and the two builds agree to 1e-12."""
    without = render(print_module(lowered(name)), "c")
    for method in ("vi", "rk4"):
        ref_q, ref_w = _reference(method)
        full_q, full_w = _run(None, method)
        q, w = _run(without, method)
        for got_q, got_w in ((q, w), (full_q, full_w)):
            assert np.max(np.abs(got_q - ref_q)) < 1e-10, (name, method)
            assert np.max(np.abs(got_w - ref_w)) < 1e-10 * max(1.0, np.max(np.abs(ref_w)))
        assert np.max(np.abs(q - full_q)) < 1e-12, (name, method)


def _symbols(kernel: Kernel) -> set[str]:
    return {str(s) for a in kernel.assignments for s in a.expr.free_symbols}


def test_quadratic_puts_the_quadratic_term_into_one_matrix() -> None:
    """The bilinear pair term (listed pairs, per-pair coefficients: K is cheaper than its
    gathered loop) is marked and gets its coefficient kernel; the Lennard-Jones term, not
    quadratic, is not."""
    full, without = lowered(), lowered("quadratic")
    assert full.quadratic == 3 * N and without.quadratic == 0
    marked = [bool(t.quadratic) for t in full.terms]
    assert marked.count(True) == 1
    assert any(k.name.endswith("_quad") for k in full.kernels)


def test_reciprocal_gives_the_kernels_that_divide_by_the_mass_its_inverse() -> None:
    """vi_pos, vi_vel, rhs_diag and RATTLE's kernels only divide by m: they take mi and do
    no division; the kinetic energy multiplies by m and keeps it."""
    full, without = lowered(), lowered("reciprocal")
    for name in ("vi_pos", "vi_vel", "rhs_diag", "rattle_pos", "rattle_vel"):
        names = [a.name for a in full.kernel(name).inputs]
        assert "mi" in names and "m" not in names, name
        assert [a.name for a in without.kernel(name).inputs].count("m") == 1
        assert kernel_profile(_kernel(full, name)).div < kernel_profile(_kernel(without, name)).div
    assert "m" in [a.name for a in full.kernel("kin_body").inputs]


def test_factor_lets_cse_share_the_pair_difference() -> None:
    """With common factors pulled out of the sums, the Lennard-Jones gradient costs fewer
    operations after cse."""
    name = next(t.gradient for t in lowered().terms if t.rows)
    with_f = kernel_profile(_kernel(lowered(), name)).total
    without = kernel_profile(_kernel(lowered("factor"), name)).total
    assert with_f < without


def test_hoist_moves_parameter_only_work_out_of_the_kernels() -> None:
    """sigma**2 powers and 4*eps factors become context constants: the pair kernels read no
    parameter and cost fewer multiplications; without the pass there are no constants."""
    full, without = lowered(), lowered("hoist")
    assert full.constants > 0 and without.constants == 0
    params = set(passes_system().parameter_names)
    t = next(t for t in full.terms if t.rows)
    for name in (t.value, t.gradient):
        assert not params & _symbols(_kernel(full, name)), name
        assert "p" not in [a.name for a in full.kernel(name).inputs]
        assert params & _symbols(_kernel(without, name)), name
        assert kernel_profile(_kernel(full, name)).mul < kernel_profile(_kernel(without, name)).mul


def test_strength_leaves_no_pow_and_one_division_per_denominator() -> None:
    """After `strength`: no kernel calls pow() (x**(3/2) is a square root and a product, the
    Lennard-Jones powers products of one reciprocal); without it the body term's x**(3/2)
    and x**(1/2) are pow calls."""
    full, without = lowered(), lowered("strength")
    calls = sum(kernel_profile(k).call for k in full.kernels if isinstance(k, Kernel))
    assert calls == 0
    assert sum(kernel_profile(k).call for k in without.kernels if isinstance(k, Kernel)) > 0
    for k in full.kernels:
        assert isinstance(k, Kernel)
        dens = [
            e.base
            for a in k.assignments
            for e in sp.preorder_traversal(a.expr)
            if isinstance(e, sp.Pow) and e.exp.is_negative
        ]
        assert len(dens) == len(set(dens)), k.name


def test_powers_writes_integer_powers_as_products() -> None:
    """No integer power is left for pow(): each is a product."""
    for k in lowered().kernels:
        assert isinstance(k, Kernel)
        for a in k.assignments:
            for e in sp.preorder_traversal(a.expr):
                if isinstance(e, sp.Pow) and e.exp.is_Integer:
                    assert e.exp == -1, (k.name, e)


def test_layout_lays_all_pairs_out_as_rows() -> None:
    """The Lennard-Jones term over all pairs (no per-pair data, not in K) becomes rows; the
    emitted C loops over rows with a SIMD reduction."""
    full, without = lowered(), lowered("layout")
    assert [t.rows for t in full.terms].count(True) == 1
    assert not any(t.rows for t in without.terms)
    c = render(print_module(full), "c")["passes.c"]
    assert "PASSES_SIMD_SUM(a0, a1, a2)" in c


def test_opcount_counts_operations_as_printed() -> None:
    """The counts by kind against hand counts; the emitted file lists every pass."""
    x, y = sp.symbols("x y")
    assert profile([x * y + 2 * x]) == Ops(add=1, mul=2)
    assert profile([x / y, 1 / x]) == Ops(mul=0, div=2)
    assert profile([sp.sqrt(x) * y, x ** sp.Rational(-1, 2)]) == Ops(mul=1, div=1, sqrt=2)
    assert profile([x**5, sp.exp(x), x ** sp.Rational(1, 3)]) == Ops(mul=4, call=2)
    c = render(print_module(lowered()), "c")["passes.c"]
    for name, _ in PIPELINE:
        assert f" *   {name}: " in c


def _substituted(kernel: Kernel) -> dict[tuple[str, int], sp.Expr]:
    """Each output slot of a lowered kernel with its temporaries substituted back."""
    values: dict[sp.Symbol, sp.Expr] = {}
    out = {}
    for a in kernel.assignments:
        expr = a.expr.xreplace(values)
        if a.temp is not None:
            values[a.temp] = expr
        else:
            assert a.output is not None
            out[a.output] = expr
    return out


def test_cse_is_deterministic_and_keeps_every_output() -> None:
    """cse alone on the unlowered kernels: temporaries x0, x1, ... in order, the same names
    from a cleared cache, and each output, its temporaries substituted back, equal to the
    derived expression at random arguments (evaluated by SymPy, 1e-12 relative)."""
    from s2gen.passes.cse import cse_pass, lower_kernel

    module = sphere_module(passes_system())
    first = cse_pass(module)
    lower_kernel.cache_clear()
    second = cse_pass(module)
    rng = np.random.default_rng(5)
    derived = {k.name: k for k in module.kernels}
    checked = 0
    for k1, k2 in zip(first.kernels, second.kernels, strict=True):
        assert isinstance(k1, Kernel) and k1.assignments == k2.assignments, k1.name
        temps = [str(a.temp) for a in k1.assignments if a.temp is not None]
        assert temps == [f"x{i}" for i in range(len(temps))], k1.name
        inputs = {s: rng.uniform(0.5, 1.5) for arg in k1.inputs for s in arg.symbols}
        params = {s: rng.uniform(0.5, 1.5) for s in passes_system().parameter_symbols}
        at = {**inputs, **params}
        lowered_outputs = _substituted(k1)
        for out in derived[k1.name].outputs:
            for slot, expr in enumerate(out.exprs):
                want = complex(sp.N(sp.sympify(expr).xreplace(at)))
                got = complex(sp.N(sp.sympify(lowered_outputs[(out.name, slot)]).xreplace(at)))
                assert abs(got - want) <= 1e-12 * max(1.0, abs(want)), (k1.name, out.name)
                checked += 1
    assert checked > 40


def test_calls_follow_each_kernels_signature() -> None:
    """Every call site binds each kernel input and output, in the kernel's order; every kernel
    the module lowers is called."""
    module = lowered()
    kernels = {k.name: k for k in module.kernels}
    assert module.calls
    for call in module.calls:
        k = kernels[call.kernel]
        assert len(call.inputs) == len(k.inputs), call.site
        assert len(call.outputs) == len(k.outputs), call.site
    called = {c.kernel for c in module.calls}
    per_call = {"context"} | {k.name for k in module.kernels if k.name.endswith("_table")}
    assert set(kernels) - called <= per_call | {"t0_quad", "inertia"}, set(kernels) - called


@pytest.mark.parametrize("system", ["passes", "double_pendulum", "rope"])
def test_workspace_buffers_are_disjoint_and_fit_work_size(system: str) -> None:
    """Each function's buffers are disjoint and contiguous from 0; the largest layout is
    `work_base`, within `work_size`, and the header's WORK_SIZE is `work_size`."""
    from s2gen.build import header_macro
    from s2gen.passes import lower_system
    from s2gen.systems import builtin

    module = lowered() if system == "passes" else lower_system(builtin(system))
    assert module.layouts
    for lay in module.layouts:
        end = 0
        for b in lay.buffers:
            assert b.offset == end and b.size >= 0, (lay.name, b.name)
            end = b.offset + b.size
        assert lay.size <= module.work_base, lay.name
    assert module.work_base == max(lay.size for lay in module.layouts) <= module.work_size
    header = render(print_module(module), "c")[f"{module.name}.h"]
    assert header_macro(header, module.name, "WORK_SIZE") == module.work_size


@pytest.mark.parametrize("system", ["double_pendulum", "rope", "springs4"])
def test_workspace_lays_out_what_the_selected_parts_read(system: str) -> None:
    """The layouts are those the module's parts declare (and the per-call context); without
    the driver part its run layouts are gone and `work_base` is the largest of the rest."""
    from dataclasses import replace

    from s2gen.parts import selected
    from s2gen.passes import lower_system
    from s2gen.passes.workspace import CONTEXT, workspace_pass
    from s2gen.systems import builtin, resolve

    spec = Path(__file__).parent / "specs" / "springs4.toml"
    module = lower_system(resolve(str(spec)) if system == "springs4" else builtin(system))
    declared = {lay for part in selected(module) for lay, _ in part.buffers}
    names = {lay.name for lay in module.layouts}
    assert names - {CONTEXT} <= declared and CONTEXT in names
    assert declared - names <= {"explicit"}, "only the explicit VI's driver may be absent"
    runs = {"rk45", "dop853", "geometric", "fixed", "integrate", "explicit"}
    assert runs & names
    without = workspace_pass(replace(module, parts=tuple(p for p in module.parts if p != "driver")))
    kept = {lay.name for lay in without.layouts}
    assert kept == names - runs
    rest = [lay.size for lay in without.layouts if lay.name not in (CONTEXT, "carry")]
    assert without.work_base == max(rest) <= module.work_base
