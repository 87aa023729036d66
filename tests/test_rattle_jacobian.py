"""RATTLE's step Jacobians (step_jacobian() of a closed module for rattle, rattle4, rattle6,
rattle8: the implicit function theorem on its constrained Stormer-Verlet equations,
`s2gen.equations.rattle_jacobian`) against independent answers: central differences of the
emitted RATTLE step along the tangent basis, the embedding coordinates and the parameters, on
each inertia solver (dense, diagonal, banded, max-index), and the symplecticity of A in the
canonical form written from M (`test_jacobian._symplectic_form`), which RK4's A does not
keep. The NumPy module's are held to the C's in `test_numpy_jacobian`."""

from __future__ import annotations

import numpy as np
import pytest
from test_chains import banded_chain
from test_jacobian import EXACT, _central, _symplectic_form

from s2gen import load
from s2gen.runtime.model import Model

H = 0.01
_MODELS: dict[str, Model] = {}


def _model(key: str, request: pytest.FixtureRequest) -> Model:
    """The conftest fixtures' double pendulum (dense M) and four pendula (diagonal M, springs),
    a chain with a banded M and the pendulum chain (max-index M)."""
    if key in ("double", "four"):
        return request.getfixturevalue(key)  # type: ignore[no-any-return]
    if key not in _MODELS:
        _MODELS[key] = Model(banded_chain(9, 1) if key == "banded" else load("pendulum_chain"))
    return _MODELS[key]


def _start(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """The spec's state with every velocity turned by a body-dependent tangent amount."""
    s = model.system
    q = np.asarray(s.q0, float)
    rng = np.random.default_rng(7)
    return q, np.asarray(s.omega0, float) + np.cross(q, rng.normal(scale=0.5, size=q.shape))


def _step(model: Model, x: np.ndarray, name: str, **kw: object) -> np.ndarray:
    n = model.system.n
    q, w = model.step(x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), H, name, EXACT, **kw)  # type: ignore[arg-type]
    return np.concatenate([np.ravel(q), np.ravel(w)])


CASES = [
    ("double", "rattle"),
    ("double", "rattle4"),
    ("four", "rattle"),
    ("four", "rattle6"),
    ("banded", "rattle"),
    ("chain", "rattle"),
    ("chain", "rattle8"),
]


@pytest.mark.parametrize(("key", "name"), CASES)
def test_rattle_jacobian_matches_central_differences(
    key: str, name: str, request: pytest.FixtureRequest
) -> None:
    """A (tangent and embedding) and P against central differences of the emitted RATTLE
    step, relative agreement 1e-6; RATTLE keeps T(S^2)^n, so tangent displacements stay
    tangent and nothing is projected away."""
    model = _model(key, request)
    s = model.system
    q0, w0 = _start(model)
    x0 = np.concatenate([np.ravel(q0), np.ravel(w0)])
    tan = model.linearize(q0, w0, H, name, options=EXACT)
    emb = model.linearize(q0, w0, H, name, basis="embedding", options=EXACT)
    after = np.concatenate([np.ravel(emb.q), np.ravel(emb.omega)])
    assert np.allclose(after, _step(model, x0, name), 0, 1e-14)

    def f(x: np.ndarray) -> np.ndarray:
        return _step(model, x, name)

    scale = np.abs(emb.A).max()
    along = _central(f, x0, tan.basis_in)
    assert np.abs(tan.A - tan.basis_out.T @ along).max() <= 1e-6 * scale
    assert np.abs(tan.basis_out @ tan.A - along).max() <= 1e-6 * scale
    assert np.abs(emb.A - _central(f, x0, np.eye(6 * s.n))).max() <= 1e-6 * scale
    base = dict(zip(s.parameter_names, s.parameter_values))
    fp = np.zeros_like(emb.P)
    for k, pname in enumerate(s.parameter_names):
        eps = 1e-6 * max(abs(base[pname]), 1.0)
        ends = [
            _step(model, x0, name, params={**base, pname: base[pname] + e}) for e in (eps, -eps)
        ]
        fp[:, k] = (ends[0] - ends[1]) / (2 * eps)
    assert np.abs(emb.P - fp).max() <= 1e-6 * np.abs(fp).max()


@pytest.mark.parametrize(
    ("key", "name"), [("double", "rattle"), ("double", "rattle4"), ("four", "rattle")]
)
def test_rattle_jacobian_is_symplectic(key: str, name: str, request: pytest.FixtureRequest) -> None:
    """A^T J(x+) A = J(x) to 1e-12, J the canonical form sum dP_i ^ dq_i (P = M qdot) in the
    tangent bases; RK4's A does not preserve it (the test can fail)."""
    model = _model(key, request)
    q0, w0 = _start(model)
    for meth, exact in ((name, True), ("rk4", False)):
        lin = model.linearize(q0, w0, 0.05, meth, options=EXACT)
        j_in = _symplectic_form(model, q0, w0, lin.basis_in)
        j_out = _symplectic_form(model, lin.q, lin.omega, lin.basis_out)
        err = np.abs(lin.A.T @ j_out @ lin.A - j_in).max() / np.abs(j_in).max()
        assert bool(err < 1e-12) == exact, (meth, err)


def test_driven_rattle_has_no_step_jacobian(driven: Model) -> None:
    """driven_double (forces with a dense M) integrates with no RATTLE method, so it has no
    RATTLE Jacobian: refused in one line naming the methods it takes (the driven modules'
    that have them: `test_driven_rattle_jacobian`)."""
    s = driven.system
    with pytest.raises(ValueError, match="method 'rattle' has no step Jacobian.*vi8$"):
        driven.linearize(s.q0, s.omega0, H, "rattle")
