"""The step Jacobians three ways: the emitted C and NumPy step_jacobian() (derived symbolically
by the generator) and the reference's complex-step derivative of its own step (no derived
equation: `s2gen.reference.step_jacobian`) agree to 1e-10 in A, B and P; the reference's
Jacobian agrees with central differences of the reference step; and a derivative that loses
its imaginary part on the way (a float cast left in the gradient) is caught by the
comparison. Every case takes well under a second once built (the file runs in about 15 s on
2 cores with a warm cache), so all run by default."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from docs_text import code_blocks, page, section

from s2gen import load
from s2gen.methods import Family, method
from s2gen.reference.forced import DrivenProblem
from s2gen.reference.step_jacobian import reference_step, step_jacobian
from s2gen.runtime.linearize import Linearization, tangent_basis
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options

#: Steps exactly from the state given (no unit check). Newton's last update below 1e-13 leaves
#: an error of round-off (it converges quadratically) and a complex-step derivative good to
#: about that; the reference's RATTLE multipliers stall near 1.5e-14 at these states, so the
#: default 1e-14 can fail there.
TOL = 1e-13
EXACT = Options(unit_tol=0.0, newton_tol=TOL)
H = 0.01
T = 0.3
DRIVEN = "tests/specs/driven_double.toml"  # coupled M, velocity-dependent forces, V(q, t), an input
RING = "tests/specs/driven_ring.toml"  # diagonal M, an input in V as well as in the forces

CASES = [
    ("double_pendulum", "vi"),  # coupled M: Newton on the Cayley parameters
    ("double_pendulum", "rk4"),
    ("double_pendulum", "rattle"),
    ("double_pendulum", "vi4"),
    ("rope:n=6", "vi"),  # a structured chain: max-index M, chain and body terms
    ("dipoles", "vi"),  # 16 bodies, a pair term over listed pairs, |l| in the coupling
    (DRIVEN, "vi"),
    (DRIVEN, "rk4"),
    (RING, "vi"),
]
_MODELS: dict[tuple[str, str], Model] = {}


def _model(spec: str, backend: str) -> Model:
    if (spec, backend) not in _MODELS:
        _MODELS[spec, backend] = Model(load(spec), backend=backend)
    return _MODELS[spec, backend]


def _start(spec: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The spec's initial state with every velocity turned by a body-dependent amount (kept
    tangent, so that no derivative is degenerate) and the inputs moved off their defaults."""
    s = load(spec)
    q = np.asarray(s.q0, float)
    w = np.asarray(s.omega0, float) + np.cross(q, np.random.default_rng(5).normal(size=q.shape))
    u = np.asarray(s.inputs.values, float) + 0.1 if s.inputs.names else None
    return q, w, u


def _rel(X: np.ndarray, Y: np.ndarray) -> float:
    """max |X - Y| over the entries, relative to the spectral norm of X (0 for no entries)."""
    if X.size == 0:
        return 0.0
    return float(np.abs(X - Y).max() / np.linalg.norm(X, 2))


def _columns(X: np.ndarray, Y: np.ndarray) -> float:
    """The worst column of `_rel` (each parameter's derivative on its own scale)."""
    return max((_rel(X[:, [k]], Y[:, [k]]) for k in range(X.shape[1])), default=0.0)


def _linearizations(spec: str, name: str, basis: str) -> dict[str, Linearization]:
    q, w, u = _start(spec)
    return {
        backend: _model(spec, backend).linearize(
            q, w, H, name, t=T, u=u, basis=basis, options=EXACT
        )
        for backend in ("c", "numpy", "reference")
    }


@pytest.mark.parametrize(("spec", "name"), CASES)
def test_c_numpy_and_reference_jacobians_agree(spec: str, name: str) -> None:
    """A, B and P in the tangent basis from the three derivations agree to 1e-10 (relative to
    the matrix norm; P column by column), and in the embedding coordinates on T(S^2)^n:
    A along the tangent basis, B and P whole. The VI with a coupled M is written differently in
    the two (the same equations on T(S^2)^n, different expressions off it), so its embedding A
    along q_i (off the sphere) differs, and the VI's embedding A is compared on the tangent
    space only; RATTLE's and the Runge-Kutta methods' are compared whole."""
    tan = _linearizations(spec, name, "tangent")
    emb = _linearizations(spec, name, "embedding")
    c, ref = tan["c"], tan["reference"]
    assert c.A.shape == ref.A.shape and c.P.shape == ref.P.shape and c.B.shape == ref.B.shape
    for other in (tan["numpy"], ref):
        assert _rel(c.A, other.A) <= 1e-10
        assert _rel(c.B, other.B) <= 1e-10
        assert _columns(c.P, other.P) <= 1e-10
        assert np.abs(other.q - c.q).max() <= 1e-13
    E = c.basis_in
    for other in (emb["numpy"], emb["reference"]):
        assert _rel(emb["c"].A @ E, other.A @ E) <= 1e-10
        assert _rel(emb["c"].B, other.B) <= 1e-10
        assert _columns(emb["c"].P, other.P) <= 1e-10
        if method(name).family is not Family.VI:
            assert _rel(emb["c"].A, other.A) <= 1e-10


def _central(
    f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, directions: np.ndarray, eps: float
) -> np.ndarray:
    """Central differences of f at x along the columns of `directions`, extrapolated
    (4 D(eps/2) - D(eps)) / 3 (error O(eps^4)): with eps = 1e-3 the truncation stays below
    1e-10 and the implicit solves' stopping noise (1e-14 relative) costs about 1e-11."""

    def D(e: float) -> np.ndarray:
        cols = [(f(x + e * d) - f(x - e * d)) / (2 * e) for d in directions.T]
        return np.stack(cols, axis=1) if cols else np.zeros((len(f(x)), 0))

    return (4 * D(eps / 2) - D(eps)) / 3


@pytest.mark.parametrize(
    ("spec", "name"),
    [
        ("double_pendulum", "vi"),
        ("double_pendulum", "rattle"),
        (DRIVEN, "vi"),
        (DRIVEN, "rk4"),
        (DRIVEN, "rattle"),  # the emitted code has no driven RATTLE Jacobian: this is the check
    ],
)
def test_reference_jacobian_matches_central_differences(spec: str, name: str) -> None:
    """The complex-step A (along the tangent basis and the 6n coordinates), B and P against
    central differences of the same reference step (`_central`: their error is about 1e-10):
    relative agreement 1e-7 (P column by column, each parameter's step scaled by its value)."""
    s = load(spec)
    q, w, u0 = _start(spec)
    n, ni = s.n, len(s.inputs.names)
    u = np.zeros(0) if u0 is None else u0
    p = np.asarray(s.parameter_values, float)
    qn, wn, A, B, P = step_jacobian(s, name, T, H, q, w, u0, p, TOL)
    step = reference_step(s, name, p, T, H, TOL)

    def flat(qw: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        return np.concatenate([np.ravel(qw[0]), np.ravel(qw[1])])

    def in_state(x: np.ndarray) -> np.ndarray:
        return flat(step(x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), u))

    x = np.concatenate([q.ravel(), w.ravel()])
    assert np.array_equal(in_state(x), np.concatenate([qn.ravel(), wn.ravel()]))
    E = tangent_basis(q, w)
    assert _rel(A @ E, _central(in_state, x, E, 1e-3)) <= 1e-7
    assert _rel(A, _central(in_state, x, np.eye(6 * n), 1e-3)) <= 1e-7
    assert _rel(B, _central(lambda v: flat(step(q, w, v)), u, np.eye(ni), 1e-3)) <= 1e-7

    def in_params(pp: np.ndarray) -> np.ndarray:
        return flat(reference_step(s, name, pp, T, H, TOL)(q, w, u))

    scale = np.maximum(1.0, np.abs(p))  # each parameter stepped by 1e-3 of its size
    assert _columns(P, _central(in_params, p, np.diag(scale), 1e-3) / scale) <= 1e-7
    assert ni == B.shape[1] and P.shape == (6 * n, len(p))


def test_a_dropped_imaginary_part_fails_the_cross_check(monkeypatch: pytest.MonkeyPatch) -> None:
    """With the potential's gradient cast to real inside the reference step (the imaginary
    part, the derivative, lost where a float cast would lose it), the reference's A no longer
    agrees with the emitted one: the comparison above has teeth."""
    spec, name = "rope:n=6", "vi"  # V not linear in q (the pendulums' is: dV/dq constant)
    c = _linearizations(spec, name, "tangent")["c"]
    gradient = DrivenProblem.dVdq
    monkeypatch.setattr(DrivenProblem, "dVdq", lambda self, q, t, u: gradient(self, q, t, u).real)
    q, w, u = _start(spec)
    broken = _model(spec, "reference").linearize(q, w, H, name, t=T, u=u, options=EXACT)
    assert _rel(c.A, broken.A) > 1e-4


def test_reference_refuses_methods_without_a_fixed_step() -> None:
    """An adaptive method has no step Jacobian on the reference either: one line, the
    methods it takes."""
    s = load("double_pendulum")
    with pytest.raises(ValueError, match="fixed-step methods vi, vi4.*not 'rk45'"):
        _model("double_pendulum", "reference").linearize(s.q0, s.omega0, H, "rk45")


def test_docs_reference_block() -> None:
    """The block of docs/user_guide/linearization.rst's section on the reference's Jacobian,
    run as it stands: its A and P are the emitted RATTLE Jacobian's to 1e-10."""
    title = "The reference's Jacobian: an independent check"
    text = section(page("user_guide/linearization.rst"), title)
    ns: dict[str, object] = {}
    exec(compile(code_blocks(text, "python")[0], "linearization.rst", "exec"), ns)  # noqa: S102
    lin = ns["lin"]
    assert isinstance(lin, Linearization)
    s = load("double_pendulum")
    c = _model("double_pendulum", "c").linearize(s.q0, s.omega0, 0.01, "rattle")
    assert _rel(c.A, lin.A) <= 1e-10 and _columns(c.P, lin.P) <= 1e-10
