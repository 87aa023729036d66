"""Code generation: reproducibility of generated/, strict compilation, derivation identities."""

from __future__ import annotations

import difflib
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.build import STRICT_FLAGS, compile_shared, compiler
from s2gen.emit import GENERATED, clear_caches, emit, regenerate
from s2gen.equations.continuous import system_matrix_blocks
from s2gen.equations.geometry import cayley_apply, cayley_apply_tangent, dot, hat
from s2gen.runtime import get_backend
from s2gen.symbols import vector

REPO = Path(__file__).resolve().parent.parent


def test_generated_folder_is_reproducible(tmp_path: Path) -> None:
    """generated/ must equal a fresh regeneration byte for byte (`s2gen regen` rewrites it):
    one module of each kind (coupled, diagonal with term loops, cutoff, angle form). Every
    cache is cleared first; a mismatch shows a unified diff."""
    clear_caches()
    regenerate(tmp_path)
    fresh = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    kept = sorted(
        p.relative_to(REPO / "generated") for p in (REPO / "generated").rglob("*") if p.is_file()
    )
    assert fresh == kept
    for rel in fresh:
        new, old = (tmp_path / rel).read_text(), (REPO / "generated" / rel).read_text()
        if new != old:
            diff = difflib.unified_diff(
                old.splitlines(), new.splitlines(), f"generated/{rel}", "regenerated", lineterm=""
            )
            pytest.fail(
                f"generated/{rel} differs (run s2gen regen):\n" + "\n".join(list(diff)[:80])
            )
    assert {p.parts[0] for p in fresh} == {folder for folder, _, _ in GENERATED}


def test_emission_is_deterministic(system) -> None:
    """Two emissions of the same system give identical text (no dates, no set order), with
    every cache cleared in between (in-process derivations and the disk cache of emitted
    files)."""
    clear_caches()
    first = emit(system, "c", cache=False)
    clear_caches()
    assert emit(system, "c", cache=False) == first


def test_emitted_c_compiles_strictly(system, tmp_path: Path) -> None:
    """Every emitted C file compiles with -std=c99 -Wall -Wextra -Wpedantic -Werror."""
    files = emit(system, "c")
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    cc, _ = compiler()
    c_file = tmp_path / f"{system.name}.c"
    proc = subprocess.run(
        [cc, *STRICT_FLAGS, "-c", str(c_file), "-o", str(tmp_path / "x.o")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    # and the header alone is valid C++ too (extern "C" guards), as embedders include it
    header = tmp_path / "use.cc"
    header.write_text(f'#include "{system.name}.h"\nint main() {{ return 0; }}\n')
    proc = subprocess.run(
        ["g++", "-Wall", "-Werror", "-fsyntax-only", str(header)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr


def test_diagonal_systems_emit_no_coupling_code(system) -> None:
    """Nothing absent is emitted: no Newton, no linear solves, no pair loops for diagonal M."""
    text = emit(system, "c")[f"{system.name}.c"]
    words = ("_lu_solve", "_cholesky_solve", "_pair_i", "res_pair", "_coupled_solve")
    has_coupling = any(w in text for w in words)
    assert has_coupling == (not system.is_diagonal)


def test_build_cache_reuses(system) -> None:
    files = emit(system, "c")
    compile_shared(files)
    again = compile_shared(files)
    assert again.reused and again.path.exists()


def test_completed_diagonal_block_and_paper_blocks() -> None:
    """A_ii = M_ii I after completion on |q| = 1; A_ij = -M_ij hat(q_i) hat(q_j) (eq. ELwm)."""
    Aii, Aij, b = system_matrix_blocks()
    m, mij = sp.Symbol("m", positive=True), sp.Symbol("mij", real=True)
    qi, qj, wj, gi = vector("qi"), vector("qj"), vector("wj"), vector("gi")
    assert Aii == m * sp.eye(3)
    assert (Aij + mij * hat(qi) * hat(qj)).applyfunc(sp.expand) == sp.zeros(3, 3)
    expected_b = mij * dot(wj, wj) * qi.cross(qj) - qi.cross(gi)
    assert (b - expected_b).applyfunc(sp.expand) == sp.zeros(3, 1)


def test_cayley_identities() -> None:
    """q x F q = 2 f/(1 + f.f) for f orthogonal to q, and the reduced F q equals the full one."""
    # q on the unit sphere by a rational parametrization; f = a x q is orthogonal to it
    u, v = sp.symbols("u v", real=True)
    q = sp.Matrix([2 * u, 2 * v, 1 - u**2 - v**2]) / (1 + u**2 + v**2)
    f_t = vector("a").cross(q)
    lhs = q.cross(cayley_apply_tangent(f_t, q))
    rhs = 2 * f_t / (1 + dot(f_t, f_t))
    assert (lhs - rhs).applyfunc(sp.simplify) == sp.zeros(3, 1)
    full = cayley_apply(f_t, q) - cayley_apply_tangent(f_t, q)
    assert full.applyfunc(sp.simplify) == sp.zeros(3, 1)
    f, q = vector("f"), vector("q")
    # and the full Cayley map keeps length for any f (numerically)
    rng = np.random.default_rng(1)
    fn, qn = rng.normal(size=3), rng.normal(size=3)
    subs = {**dict(zip(f, fn)), **dict(zip(q, qn / np.linalg.norm(qn)))}
    out = np.array(cayley_apply(f, q).subs(subs).evalf(), dtype=float).ravel()
    assert abs(np.linalg.norm(out) - 1.0) < 1e-14


def test_rhs_satisfies_euler_lagrange(system) -> None:
    """The emitted field solves q_i x (sum_j M_ij qddot_j + dV/dq_i) = 0 (paper's EL0)."""
    be = get_backend(system, "c")
    rng = np.random.default_rng(3)
    q = system.q0 + 0.1 * rng.normal(size=system.q0.shape)
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = rng.normal(size=q.shape)
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    p = np.array(system.parameter_values)
    dq, dw = be.rhs(q, w, p)
    M = system.inertia_numeric()
    g = be.gradient(q, p)
    qdd = np.cross(dw, q) - np.einsum("ij,ij->i", w, w)[:, None] * q
    residual = np.cross(q, M @ qdd + g)
    scale = np.max(np.abs(M)) * np.max(np.abs(qdd)) + np.max(np.abs(g))
    assert np.max(np.abs(residual)) < 1e-12 * scale
    assert np.max(np.abs(dq - np.cross(w, q))) < 1e-15 * np.max(np.abs(w))
