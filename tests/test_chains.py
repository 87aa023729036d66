"""Structured inertia: detection (with near misses), the per-body spec, and the O(n) solvers
against the dense ones and the reference.

The structured solvers (banded and max-index M) must compute what the dense ones compute:
over 100 steps of the VI, RATTLE and RK4 the two paths agree to 1e-12 (q, and omega relative
to its largest value) on chains where round-off is not amplified beyond that by the motion
itself, Newton takes the same number of iterations (with a stopping tolerance above the
round-off floor of its last update), and a structure is never assumed where M does not have
it, for every parameter value.
"""

from __future__ import annotations

import re
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.build import STRICT_FLAGS, compiler
from s2gen.cli import main
from s2gen.emit import emit
from s2gen.equations.operators import verify_factorization
from s2gen.equations.structure import choose_solver
from s2gen.inertia import INDEX, ChainInertia, InertiaKind, chain_cholesky_pivots, detect
from s2gen.runtime import IntegrationError, Options, simulate
from s2gen.spec import define_system, load_spec_text
from s2gen.system import SpecError, SpecWarning, System
from s2gen.systems import builtin, builtin_options, resolve
from s2gen.systems.chains import rope
from s2gen.systems.paper import elastic_rod, rod_inertia

STEPS = 100


def _with_solver(system: System, solver: str) -> System:
    """The same system (same M, same form of M) with its coupled solves forced."""
    return System.create(
        name=system.name,
        n=system.n,
        parameters=system.parameters,
        inertia=system.chain if system.chain is not None else system.inertia,
        potential=system.potential,
        q0=system.q0,
        omega0=system.omega0,
        run=system.run,
        origin=system.origin,
        terms=system.terms,
        inertia_solver=solver,
    )


def banded_chain(n: int = 9, width: int = 1, solver: str = "auto") -> System:
    """n bodies whose M couples neighbours up to `width` apart (a banded M), with bending
    springs and a one-body potential, from a random tangent initial state."""
    M = [["0"] * n for _ in range(n)]
    for i in range(n):
        M[i][i] = f"m*(2 + {i % 3})"
        for k in range(1, width + 1):
            if i + k < n:
                M[i][i + k] = M[i + k][i] = f"c*m/{k}"
    rng = np.random.default_rng(5)
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = rng.normal(size=(n, 3))
    w -= np.sum(w * q, axis=1)[:, None] * q
    return define_system(
        name="banded",
        bodies=n,
        parameters={"m": 1.0, "c": 0.3, "k": 2.0},
        inertia=M,
        pair_terms=[{"V": "k*(1 - dot(qi, qj))", "pairs": "chain"}],
        body_terms=[{"V": "q[2]"}],
        initial_q=q.tolist(),
        initial_omega=w.tolist(),
        run={"h": 0.01, "T": 1.0},
        inertia_solver=solver,
    )


# ------------------------------------------------------------------------------ derivation
def test_factored_kernels_are_the_pair_kernels() -> None:
    """Every pair kernel is M_ij times (body i's factor) applied to body j's source (SymPy)."""
    assert verify_factorization()


# ------------------------------------------------------------------------------ detection
def _generators_rebuild(M: sp.MatrixBase, subs: dict[sp.Symbol, float]) -> None:
    s = detect(sp.ImmutableSparseMatrix(M), subs)
    assert s.kind is InertiaKind.MAX_INDEX
    g = s.generators
    n = M.shape[0]
    num = np.array(M.subs(subs).evalf(), dtype=float)
    a = np.array([float(sp.sympify(x).subs(subs)) for x in g.scale])
    c = np.array([float(sp.sympify(x).subs(subs)) for x in g.max_index])
    d = np.array([float(sp.sympify(x).subs(subs)) for x in g.diagonal])
    idx = np.arange(n)
    rebuilt = a[:, None] * a[None, :] * c[np.maximum(idx[:, None], idx[None, :])]
    rebuilt[idx, idx] = d
    assert np.allclose(rebuilt, num, rtol=1e-13, atol=0)


def test_detects_max_index_in_given_matrices() -> None:
    """The chain of tests/specs (point masses, symbolic), both rod inertias as numbers."""
    chain = resolve("tests/specs/chain4.toml")
    assert chain.structure.kind is InertiaKind.MAX_INDEX
    _generators_rebuild(chain.inertia, dict(zip(chain.parameter_symbols, chain.parameter_values)))
    for kind in ("paper", "physical"):
        _generators_rebuild(rod_inertia(8, kind), {})


def test_detects_bands_and_diagonals() -> None:
    assert banded_chain(9, 1).structure.kind is InertiaKind.BANDED
    assert banded_chain(9, 1).structure.bandwidth == 1
    assert banded_chain(12, 2).structure.bandwidth == 2
    assert builtin("four_pendula").structure.kind is InertiaKind.DIAGONAL


@pytest.mark.parametrize(
    "case",
    [
        "parameter_zero_at_spec",  # symbolically not max-index, numerically so at the spec
        "numbers_off_by_1e-9",
        "equal_generators",  # D + c 11^T: max-index form, but C is singular
        "corner_parameter_zero",  # banded at the spec values only
    ],
)
def test_near_misses_are_not_structured(case: str) -> None:
    m, eps = sp.symbols("m eps", real=True)
    n = 5
    base = sp.Matrix(n, n, lambda i, j: m * (n - max(i, j)) + (m if i == j else 0))
    subs = {m: 1.0, eps: 0.0}
    if case == "parameter_zero_at_spec":
        M = base.copy()
        M[3, 1] = M[1, 3] = M[3, 1] + eps * m
        expect = InertiaKind.DENSE
    elif case == "numbers_off_by_1e-9":
        M = base.subs(m, 1)
        M[3, 1] = M[1, 3] = M[3, 1] * (1 + sp.Float(1e-9))
        expect = InertiaKind.DENSE
    elif case == "equal_generators":
        M = sp.Matrix(n, n, lambda i, j: 3 * m if i == j else m)
        expect = InertiaKind.DENSE
    else:
        M = sp.diag(*([3 * m] * n))
        for i in range(n - 1):
            M[i, i + 1] = M[i + 1, i] = m
        M[0, n - 1] = M[n - 1, 0] = eps
        expect = InertiaKind.DENSE
    assert detect(sp.ImmutableSparseMatrix(M), subs).kind is expect


def test_identically_zero_entries_keep_the_band_and_proofs_see_through_rewriting() -> None:
    """An entry that simplifies to 0 is not a coupling; a max-index M written with other but
    equal expressions is still proven max-index."""
    a, b, m = sp.symbols("a b m", real=True)
    M = sp.diag(*([3 * m] * 5))
    for i in range(4):
        M[i, i + 1] = M[i + 1, i] = m
    M[0, 4] = M[4, 0] = (a + b) ** 2 - a**2 - 2 * a * b - b**2
    s = detect(sp.ImmutableSparseMatrix(M), {a: 1.0, b: 2.0, m: 1.0})
    assert (s.kind, s.bandwidth) == (InertiaKind.BANDED, 1)
    chain = sp.Matrix(4, 4, lambda i, j: m * (5 - max(i, j)) if i != j else m * (9 - i))
    chain[2, 1] = chain[1, 2] = m * (a + 3) - m * a  # = 3 m, the max-index value
    assert detect(sp.ImmutableSparseMatrix(chain), {a: 1.0, m: 1.0}).kind is InertiaKind.MAX_INDEX


def test_a_per_body_inertia_without_the_structure_falls_back_to_dense() -> None:
    """max_index constant (C singular): a warning, the dense solvers, the right motion."""
    with pytest.warns(SpecWarning, match="dense solves"):
        s = define_system(
            name="flat",
            bodies=4,
            parameters={"m": 1.0, "k": 1.0},
            diagonal="3*m",
            max_index="m",
            pair_terms=[{"V": "k*(1 - dot(qi, qj))", "pairs": "chain"}],
            initial_q=[[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]],
            initial_omega=[[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 0, 0]],
        )
    assert s.structure.kind is InertiaKind.DENSE and choose_solver(s) is InertiaKind.DENSE
    c = simulate(s, "vi", "c", h=0.01, T=0.5)
    r = simulate(s, "vi", "reference", h=0.01, T=0.5)
    assert np.max(np.abs(c.q - r.q)) < 1e-12


def test_chain_cholesky_decides_positive_definiteness() -> None:
    rng = np.random.default_rng(2)
    n = 40
    d, a = rng.uniform(2.0, 3.0, n), rng.uniform(0.5, 1.5, n)
    c = np.cumsum(rng.uniform(0.1, 1.0, n)[::-1])[::-1]
    idx = np.arange(n)
    M = a[:, None] * a[None, :] * c[np.maximum(idx[:, None], idx[None, :])]
    M[idx, idx] = d + a * a * c
    assert np.allclose(chain_cholesky_pivots(np.diag(M), a, c), np.diag(np.linalg.cholesky(M)) ** 2)
    for shift in (0.01, 0.1, 0.5, 1.0, 2.0):  # D < 0: positive definite or not, as numpy says
        M[idx, idx] = a * a * c - shift
        definite = bool(np.linalg.eigvalsh(M)[0] > 0)
        assert bool(np.all(chain_cholesky_pivots(np.diag(M), a, c) > 0)) == definite, shift


# ------------------------------------------------------------------------------ spec
PER_BODY = """
name = "links"
bodies = 5
[parameters]
g = 9.81
[inertia]
diagonal = "l**2*T"
max_index = "T"
scale = "l"
[inertia.data]
l = [0.3, 0.25, 0.2, 0.2, 0.15]
T = [1.7, 1.2, 0.8, 0.5, 0.3]
[potential]
V = "g*dot(e3, q5)"
"""


def test_per_body_inertia_equals_the_matrix_it_stands_for() -> None:
    s = load_spec_text(PER_BODY)
    assert s.matrix is None and s.structure.kind is InertiaKind.MAX_INDEX
    l, t = [0.3, 0.25, 0.2, 0.2, 0.15], [1.7, 1.2, 0.8, 0.5, 0.3]
    expected = [[l[i] * l[j] * t[max(i, j)] for j in range(5)] for i in range(5)]
    assert np.allclose(s.inertia_numeric(), expected, rtol=1e-15)
    rod = define_system(
        name="rod",
        bodies=6,
        parameters={"u": 2.0},
        potential=0,
        diagonal="u*(1/3 + n - i)",
        max_index="u*(n - i + 1)/2",
    )
    assert np.allclose(rod.inertia_numeric(), 2.0 * np.array(rod_inertia(6), dtype=float))


def test_a_per_body_diagonal_is_evaluated_body_by_body() -> None:
    """A diagonal given as one expression per body: code that loops over the bodies (not n
    outputs of one kernel), the same motion on every backend."""
    s = define_system(
        name="beads",
        bodies=5,
        parameters={"m": 1.0},
        diagonal="m*(1 + i/n)",
        body_terms=[{"V": "q[2]"}],
        initial_q=[[1, 0, 0]] * 5,
        initial_omega=[[0, 1, 0]] * 5,
    )
    assert s.structure.kind is InertiaKind.DIAGONAL
    assert "_k_inertia_body" in emit(s, "c")["beads.c"]
    runs = [simulate(s, "vi", b, h=0.01, T=0.2) for b in ("c", "numpy", "reference")]
    assert max(np.max(np.abs(r.q - runs[2].q)) for r in runs[:2]) < 1e-14


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (('scale = "l"', 'scale = "l*x"'), "scale: unknown name 'x'"),
        (("T = [1.7, 1.2, 0.8, 0.5, 0.3]", "T = [1.7, 1.2]"), r"data.T: expected 5 numbers"),
        (("[parameters]", "[parameters]\ni = 1.0"), "'i' clashes"),
        (("T = [1.7, 1.2, 0.8, 0.5, 0.3]", "T = [1.7, 1.2, 0.8, 0.5, -0.3]"), "Cholesky pivot 5"),
        (('scale = "l"', 'scale = "l"\nsolver = "fastest"'), "solver: expected one of"),
        (('diagonal = "l**2*T"', "diagonal = [1, 1, 1, 1, 1]"), "one expression per body"),
        (('scale = "l"', 'scale = "l*q1[0]"'), "not allowed here"),
    ],
)
def test_per_body_inertia_errors_name_the_key(edit: tuple[str, str], message: str) -> None:
    with pytest.raises(SpecError, match=message):
        load_spec_text(PER_BODY.replace(*edit), origin="links.toml")


def test_structured_solver_refused_where_m_has_no_structure() -> None:
    s = _with_solver(builtin("double_pendulum"), "structured")  # n = 2: max-index, fine
    assert choose_solver(s) is InertiaKind.MAX_INDEX
    M = [["3", "1", "2"], ["1", "3", "1"], ["2", "1", "4"]]  # not max-index, not banded
    dense = define_system(
        name="d", bodies=3, parameters={}, inertia=M, potential="q1[2]", inertia_solver="structured"
    )
    with pytest.raises(SpecError, match="neither banded nor diagonal plus max-index"):
        emit(dense, "c", cache=False)


# ------------------------------------------------------------------------------ command line
def test_builtin_options_from_the_spec_string(capsys: pytest.CaptureFixture[str]) -> None:
    assert resolve("rope:n=7,kappa=0.3").n == 7
    assert resolve("elastic_rod:n=9,inertia=physical").name == "elastic_rod_physical"
    for spec, message in [
        ("rope:n=seven", "option n expects an integer, got 'seven'"),
        ("rope:stiffness=2", "unknown option or parameter 'stiffness' \\(known: n=20"),
        ("elastic_rod:inertia=exact", "rod inertia must be one of"),
        ("double_pendulum:n=3", "unknown option or parameter 'n' \\(known: m1, m2, l1, l2, g"),
        ("rope:n=3,n=4", "given twice"),
    ]:
        with pytest.raises(SpecError, match=message):
            resolve(spec)
    assert str(builtin_options("elastic_rod")[0]) == "n=10"
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "rope  (n = 20, max-index inertia)" in out and "options: n=10, inertia='paper'" in out


# ------------------------------------------------------------------------------ solvers
CASES = {
    "chain4 (generators found in M)": lambda solver: _with_solver(
        resolve("tests/specs/chain4.toml"), solver
    ),
    "rod paper": lambda solver: elastic_rod(12, "paper", solver=solver),
    "rod physical": lambda solver: elastic_rod(12, "physical", solver=solver),
    "rope": lambda solver: rope(16, solver=solver),
    "pendulum chain (TOML)": lambda solver: _with_solver(builtin("pendulum_chain"), solver),
    "banded": lambda solver: banded_chain(9, 1, solver),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def pair(request: pytest.FixtureRequest) -> tuple[str, System, System]:
    make = CASES[request.param]
    return request.param, make("structured"), make("dense")


def test_solvers_chosen_as_asked(pair: tuple[str, System, System]) -> None:
    name, structured, dense = pair
    expected = InertiaKind.BANDED if name == "banded" else InertiaKind.MAX_INDEX
    assert choose_solver(structured) is expected and choose_solver(dense) is InertiaKind.DENSE
    assert "_coupled_solve" in emit(structured, "c")[f"{structured.name}.c"]


@pytest.mark.parametrize("method", ["vi", "rattle", "rk4"])
def test_structured_and_dense_agree_over_100_steps(
    pair: tuple[str, System, System], method: str
) -> None:
    name, structured, dense = pair
    h = structured.run.h
    assert h is not None
    a = simulate(structured, method, "c", h=h, T=STEPS * h)
    b = simulate(dense, method, "c", h=h, T=STEPS * h)
    scale = float(np.max(np.abs(b.omega)))
    assert np.max(np.abs(a.q - b.q)) < 1e-12, name
    assert np.max(np.abs(a.omega - b.omega)) < 1e-12 * scale, name
    assert np.max(np.abs(a.energy - b.energy)) < 1e-12 * np.max(np.abs(b.energy)), name
    # Newton: the same equations take the same iterations, once the tolerance sits above the
    # round-off floor of the last update (at 1e-14 a rope's last update is itself ~1e-14)
    if method != "rk4":
        opts = Options(newton_tol=1e-12)
        a = simulate(structured, method, "c", h=h, T=STEPS * h, options=opts, energy=False)
        b = simulate(dense, method, "c", h=h, T=STEPS * h, options=opts, energy=False)
        assert a.stats["newton_iters"] == b.stats["newton_iters"], name


@pytest.mark.parametrize(
    ("name", "method"),
    [("rod paper", "vi4"), ("rod paper", "vi"), ("rod physical", "vi"), ("rope", "vi")],
)
def test_newton_iterations_equal_at_the_default_tolerance(name: str, method: str) -> None:
    """At the default tolerance Newton stops on the update or on the update quadratic
    convergence predicts, before the last update reaches round-off: the counts match exactly."""
    make = CASES[name]
    structured, dense = make("structured"), make("dense")
    h = 1e-4 if method == "vi4" else structured.run.h
    assert h is not None
    a, b = (simulate(s, method, "c", h=h, T=STEPS * h, energy=False) for s in (structured, dense))
    assert a.stats["newton_iters"] == b.stats["newton_iters"], name


def test_structured_numpy_module_matches_the_c() -> None:
    """The NumPy module's structured solves (scipy's band solver) against the emitted C, on
    the banded chain (the max-index rod is in the agreement tests of every backend)."""
    s = banded_chain(9, 2)
    for method in ("vi", "rattle", "rk4"):
        c = simulate(s, method, "c", h=0.01, T=0.5)
        n = simulate(s, method, "numpy", h=0.01, T=0.5)
        assert np.max(np.abs(c.q - n.q)) < 1e-12 and np.max(np.abs(c.omega - n.omega)) < 1e-11


def test_rope_against_the_reference() -> None:
    """The rope (max-index M with a zero diagonal remainder: pivoting at work) against the
    independent reference integrator on its dense M."""
    s = rope(10, kappa=0.2)
    for method in ("vi", "rk4"):
        c = simulate(s, method, "c", h=1e-3, T=0.3)
        r = simulate(s, method, "reference", h=1e-3, T=0.3)
        assert np.max(np.abs(c.q - r.q)) < 1e-11
        assert np.max(np.abs(c.omega - r.omega)) < 1e-11 * np.max(np.abs(r.omega))
        assert np.max(np.abs(c.energy - r.energy)) < 1e-11 * np.max(np.abs(r.energy))


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_parameters_that_break_the_structure_are_reported(backend: str) -> None:
    """max_index = b + a (n - i + 1) has c_k = c_k+1 when a = 0: M = D + b 11^T is still
    positive definite, but the structured solve cannot use it and says so (ERR_SINGULAR)
    instead of returning a wrong answer; the dense solve handles it."""
    s = define_system(
        name="breakable",
        bodies=8,
        parameters={"a": 1.0, "b": 0.5},
        diagonal="b + a*(n - i + 1) + 1",
        max_index="b + a*(n - i + 1)",
        pair_terms=[{"V": "dot(qi, qj)", "pairs": "chain"}],
        initial_q=[[1, 0, 0]] * 8,
        initial_omega=[[0, 1, 0]] * 8,
        inertia_solver="structured",
    )
    broken = np.array([0.0, 0.5])
    with pytest.raises(IntegrationError) as info:
        simulate(s, "rk4", backend, h=0.01, T=0.1, params=broken)
    assert info.value.status == 6  # Status.SINGULAR
    dense = simulate(_with_solver(s, "dense"), "rk4", backend, h=0.01, T=0.1, params=broken)
    assert np.all(np.isfinite(dense.q))


def test_every_structured_variant_compiles_strictly(tmp_path: Path) -> None:
    """C99 with every warning an error, and C++: banded, max-index found in a matrix,
    max-index per body (the rope is in test_c_interface), and a per-body diagonal."""
    variants = [
        banded_chain(9, 2),
        _with_solver(resolve("tests/specs/chain4.toml"), "structured"),
        define_system(
            name="beads", bodies=3, parameters={"m": 1.0}, diagonal="m*i", potential="q1[2]"
        ),
    ]
    cc, _ = compiler()
    for system in variants:
        for name, text in emit(system, "c").items():
            (tmp_path / name).write_text(text)
        source = str(tmp_path / f"{system.name}.c")
        for cmd in (
            [cc, *STRICT_FLAGS, "-c", source, "-o", str(tmp_path / "x.o")],
            [
                "g++",
                "-x",
                "c++",
                "-std=c++11",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-c",
                source,
                "-o",
                str(tmp_path / "y.o"),
            ],
        ):
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            assert proc.returncode == 0, (system.name, proc.stderr[:2000])


def test_emitted_code_does_not_grow_with_n() -> None:
    """Apart from the per-body data tables and the literal n, the rope's C is the same text at
    n = 10 and n = 1000. The spec's initial state is one more table, 6 full-precision doubles
    per body, kept out of the size budget of the rest."""
    texts = [emit(rope(n), "c")["rope.c"] for n in (10, 1000)]

    def initial_table(text: str) -> int:
        found = re.search(r"rope_initial\[\d+\] = \{\n.*?\n\};", text, re.DOTALL)
        assert found is not None
        return len(found.group(0))

    def skeleton(text: str) -> str:
        kept = [line for line in text.splitlines() if not re.fullmatch(r"\s*[-+0-9., e]+,", line)]
        text = re.sub(r"\b[0-9a-f]{16}\b", "HASH", "\n".join(kept))
        return re.sub(r"\b\d+\b", "K", re.sub(r"\[\d+\]", "[N]", text))

    assert skeleton(texts[0]) == skeleton(texts[1])
    tables = [initial_table(t) for t in texts]
    assert len(texts[1]) - tables[1] - (len(texts[0]) - tables[0]) < 100 * 990


def test_per_body_chain_has_no_quadratic_inertia() -> None:
    """A 2000-link rope is built without its M: the System holds three expressions."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = rope(2000)
    assert s.matrix is None and isinstance(s.chain, ChainInertia)
    assert s.chain.diagonal.free_symbols >= {sp.Symbol("lam", real=True)}
    assert INDEX not in s.chain.max_index.free_symbols


def test_chain_angular_momentum_from_generators_equals_the_entries() -> None:
    """Trajectory.angular_momentum takes a chain's M from its per-body generators (a 1000-link
    rod's n^2 symbolic entries took a minute); it equals J from M's symbolic entries, and the
    rope's J_z (gravity along z, the pin on the axis) is conserved by the VI."""
    from s2gen.runtime.trajectory import _inertia_entries

    system = rope(12)
    assert system.matrix is None and system.chain is not None
    tr = simulate(system, "vi", "c", h=system.run.h, T=50 * system.run.h)
    J = tr.angular_momentum(system)
    entries = _inertia_entries(system, None)
    M = np.zeros((system.n, system.n))
    for (i, j), v in entries.items():
        M[i, j] = v
    v = np.cross(tr.omega, tr.q)
    expected = np.cross(tr.q, np.einsum("ij,tjk->tik", M, v)).sum(axis=1)
    assert np.max(np.abs(J - expected)) <= 1e-13 * np.max(np.abs(expected))
    assert np.max(np.abs(J[:, 2] - J[0, 2])) < 1e-10 * np.max(np.abs(expected))
