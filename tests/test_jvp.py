"""step_jvp(): the Jacobian-vector product of a step, against independent checks.

- small chains (n = 4..10: max-index M with the structured solves, banded M, diagonal M): the
  tangent equals the full step Jacobian of step_jacobian() (the dense chain rule through the
  stages, and for the VI family the dense implicit function theorem on the equations' dense
  derivatives: separate code paths) times the direction, to 1e-12 relative, for every method;
- a rope of n = 200 (no dense Jacobian there): the tangent equals central differences of the
  emitted step (rk_step() and vi_step() through ctypes, Newton converged to round-off) along
  the direction, to 1e-7 relative, and the step equals theirs;
- the refusals (dense M, a method without a tangent) are one-line errors; the page's
  example runs; the emitted C with step_jvp() compiles strictly (C99 and C++), and
  ``s2gen generate --jacobians`` emits it beyond 32 bodies.
"""

from __future__ import annotations

import ctypes
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from docs_text import code_blocks, page

from s2gen.build import STRICT_FLAGS, compiler
from s2gen.cli import main
from s2gen.emit import emit
from s2gen.methods import method
from s2gen.runtime.c import CBackend, contiguous
from s2gen.runtime.jvp import jvp_methods, step_jvp
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.spec import define_system
from s2gen.system import System
from s2gen.systems import builtin


def banded(n: int = 6) -> System:
    """n bodies whose M couples neighbours (banded), with chain springs and a body term."""
    inertia = [["0"] * n for _ in range(n)]
    for i in range(n):
        inertia[i][i] = f"m*(2 + {i % 3})"
        if i + 1 < n:
            inertia[i][i + 1] = inertia[i + 1][i] = "c*m"
    q = np.zeros((n, 3))
    q[:, 2] = 1.0
    return define_system(
        name="banded",
        bodies=n,
        parameters={"m": 1.0, "c": 0.3, "k": 2.0},
        inertia=inertia,
        pair_terms=[{"V": "k*(1 - dot(qi, qj)) + k*dot(qi, qj)**3", "pairs": "chain"}],
        body_terms=[{"V": "q[2] + q[0]*q[1]"}],
        initial_q=q.tolist(),
        initial_omega=np.zeros((n, 3)).tolist(),
        inertia_solver="structured",
    )


def _state(n: int, seed: int) -> tuple[np.ndarray, ...]:
    """A random state on T(S^2)^n and a random direction of the embedding (6n)."""
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = rng.standard_normal((n, 3))
    w -= (w * q).sum(axis=1)[:, None] * q
    return q, w, rng.standard_normal((n, 3)), rng.standard_normal((n, 3))


SMALL = {
    "rope4": lambda: builtin("rope", n=4, solver="structured"),
    "rope8": lambda: builtin("rope", n=8, solver="structured"),
    "banded": banded,
    "four_pendula": lambda: builtin("four_pendula"),
    "elastic_rod": lambda: builtin("elastic_rod"),  # a listed term (member table), n = 10
}


@pytest.fixture(scope="module", params=sorted(SMALL))
def small(request: pytest.FixtureRequest) -> Model:
    return Model(SMALL[request.param]().with_jacobians())


@pytest.mark.parametrize("name", jvp_methods(vi=True))
def test_jvp_is_the_step_jacobian_times_the_direction(small: Model, name: str) -> None:
    """A v from step_jacobian() (dense, n <= 32) against step_jvp()'s tangent, 1e-12; the
    step no longer than the spec's own (the rod is stiff)."""
    n, h = small.system.n, min(0.02, small.system.run.h or 0.02)
    q, w, dq, dw = _state(n, 3)
    lin = small.linearize(q, w, h, name, basis="embedding")
    st = small.step_jvp(q, w, h, dq, dw, name)
    want = lin.A @ np.concatenate([dq.ravel(), dw.ravel()])
    got = np.concatenate([st.dq.ravel(), st.domega.ravel()])
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    scale = max(1.0, np.abs(lin.omega).max())
    assert np.abs(st.q - lin.q).max() <= 1e-14
    assert np.abs(st.omega - lin.omega).max() <= 1e-13 * scale


@pytest.fixture(scope="module")
def rope200() -> CBackend:
    return CBackend(builtin("rope", n=200).with_jacobians())


def _rk_step(be: CBackend, name: str, h: float, q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(q+, w+) of the emitted rk_step() or vi_step() (Newton to round-off), flattened."""
    n = be.system.n
    qn, wn = np.empty((n, 3)), np.empty((n, 3))
    p = contiguous(be.default_params())
    q, w, work = contiguous(q), contiguous(w), be.library.work
    if name == "vi":
        opt = ctypes.byref(be.library.options(Options(newton_tol=1e-15, newton_maxiter=50)))
        status = be.library.fn["vi_step"](p, opt, h, q, w, qn, wn, work, None)
    else:
        status = be.library.fn["rk_step"](p, method(name).code, h, q, w, qn, wn, work)
    assert status == 0
    return np.concatenate([qn.ravel(), wn.ravel()])


@pytest.mark.parametrize("name", ["rk4", "rk2-proj", "vi"])
def test_jvp_against_central_differences_of_the_step(rope200: CBackend, name: str) -> None:
    """n = 200 (beyond the dense Jacobian): the tangent against central differences of the
    emitted step along the direction (tangent to the sphere, so that the perturbed states
    stay near it), 1e-7 relative; the step itself is rk_step()'s."""
    be, n, h = rope200, 200, 1e-3
    q, w, dq, dw = _state(n, 5)
    q = 0.9 * np.asarray(be.system.q0) + 0.1 * q  # near the rope's own state: a stiff chain
    q /= np.linalg.norm(q, axis=1)[:, None]
    w *= 0.5
    dq -= (dq * q).sum(axis=1)[:, None] * q
    tight = Options(newton_tol=1e-15, newton_maxiter=50)
    st = step_jvp(be, q, w, h, dq, dw, name, be.default_params(), tight)
    eps = 1e-6
    plus = _rk_step(be, name, h, q + eps * dq, w + eps * dw)
    minus = _rk_step(be, name, h, q - eps * dq, w - eps * dw)
    want = (plus - minus) / (2 * eps)
    got = np.concatenate([st.dq.ravel(), st.domega.ravel()])
    assert np.abs(got - want).max() <= 1e-7 * np.abs(want).max()
    x1 = _rk_step(be, name, h, q, w)
    assert np.abs(np.concatenate([st.q.ravel(), st.omega.ravel()]) - x1).max() <= 1e-13


def test_refusals() -> None:
    """A dense M and a method without a tangent: one-line ValueErrors."""
    with pytest.raises(ValueError, match="not a dense M"):
        Model(builtin("double_pendulum")).step_jvp(
            np.eye(3)[:2], np.zeros((2, 3)), 0.01, np.zeros((2, 3)), np.zeros((2, 3))
        )
    m = Model(builtin("four_pendula"))
    s = m.system
    with pytest.raises(ValueError, match="step_jvp takes rk2, rk2-proj, rk4, rk3, vi, "):
        m.step_jvp(s.q0, s.omega0, 0.01, s.q0, s.omega0, method="rattle")


def test_docs_block(rope200: CBackend) -> None:
    """The step_jvp block of docs/user_guide/linearization.rst, run as it stands: its tangent
    against central differences of the emitted step (the rope of 200 bodies it loads is the
    one above)."""
    code = code_blocks(page("user_guide/linearization.rst"), "python")[-1]
    ns: dict[str, object] = {}
    exec(compile(code, "linearization.rst", "exec"), ns)  # noqa: S102 (the page's own example)
    st, dq, rope = ns["st"], np.asarray(ns["dq"]), rope200.system
    eps = 1e-6
    q, w = np.asarray(rope.q0), np.asarray(rope.omega0)
    plus = _rk_step(rope200, "rk4", 2e-4, q + eps * dq, w)
    minus = _rk_step(rope200, "rk4", 2e-4, q - eps * dq, w)
    want = (plus - minus) / (2 * eps)
    got = np.concatenate([st.dq.ravel(), st.domega.ravel()])  # type: ignore[attr-defined]
    assert np.abs(got - want).max() <= 1e-7 * np.abs(want).max()


@pytest.mark.parametrize(
    "make",
    [
        lambda: builtin("four_pendula"),
        lambda: banded(),
        lambda: builtin("elastic_rod"),
        lambda: builtin("rope", n=40),
    ],
    ids=["diagonal", "banded", "max_index_tables", "max_index_40"],
)
def test_emitted_c_with_step_jvp_compiles_strictly(
    make: Callable[[], System], tmp_path: Path
) -> None:
    """The C with step_jvp() (diagonal, banded and max-index M; n beyond the dense Jacobians'
    32 bodies) compiles with -std=c99 -Wall -Wextra -Wpedantic -Werror, and as C++."""
    system = make().with_jacobians()
    files = emit(system, "c")
    assert "_step_jvp(" in files[f"{system.name}.h"]
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    c_file = str(tmp_path / f"{system.name}.c")
    for cmd in (
        [compiler()[0], *STRICT_FLAGS, "-c", c_file, "-o", str(tmp_path / "x.o")],
        [
            "g++",
            "-x",
            "c++",
            "-std=c++11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-c",
            c_file,
            "-o",
            str(tmp_path / "y.o"),
        ],
    ):
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        assert proc.returncode == 0, proc.stderr


def test_generate_jacobians_beyond_32_bodies(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``s2gen generate --jacobians`` for a rope of 100 bodies: step_jvp() without
    step_jacobian() (which stops at 32 bodies); a dense M of 40 bodies is refused in one line."""
    assert main(["generate", "rope:n=100", "--jacobians", "--out", str(tmp_path)]) == 0
    header = (tmp_path / "rope.h").read_text()
    assert "rope_step_jvp(" in header and "rope_step_jacobian(" not in header
    capsys.readouterr()
    assert main(["generate", "rope:n=40,solver=dense", "--jacobians", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert "--jacobians: rope: step Jacobians are emitted for systems of at most 32" in err
