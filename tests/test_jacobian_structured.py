"""The step Jacobians of larger and structured systems (the Hessian of V assembled per term
member, the field's and the VI's blocks per body and coupled pair of M) against independent
answers: central finite differences of the emitted step along the tangent basis and the
embedding coordinates (and in the parameters), and the symplecticity of the closed VI's
derivative in the canonical form written from M (the form of `test_jacobian`). Each case
builds in a few seconds (with a fresh cache, the file runs in about 20 s on 2 cores), so all
run by default."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from test_chains import banded_chain
from test_jacobian import EXACT, _central, _symplectic_form

from s2gen import load
from s2gen.methods import Family, method
from s2gen.runtime.model import Model
from s2gen.symbols import q_symbol
from s2gen.system import System

H = 0.01

#: The systems, each built once per module (spec as `load` reads it)
SPECS = {
    "chain": "pendulum_chain",  # max-index M, chain and body terms
    "dipoles": "dipoles",  # 16 bodies, a pair term over a list of pairs, diagonal M
    "rod": "elastic_rod:solver=dense",  # 10 bodies, M dense (all pairs coupled), chain terms
}
_MODELS: dict[str, Model] = {}


def _model(key: str) -> Model:
    if key not in _MODELS:
        _MODELS[key] = Model(load(SPECS[key]))
    return _MODELS[key]


def _start(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """The initial state with every velocity turned by a body-dependent amount (a state
    where the derivatives in w are not degenerate) and kept tangent."""
    s = model.system
    q = np.asarray(s.q0, float)
    rng = np.random.default_rng(7)
    w = np.asarray(s.omega0, float) + np.cross(q, rng.normal(scale=0.5, size=q.shape))
    return q, w


def _state_step(model: Model, x: np.ndarray, name: str) -> np.ndarray:
    n = model.system.n
    q, w = model.step(x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), H, name, EXACT)
    return np.concatenate([np.ravel(q), np.ravel(w)])


def _richardson(f, x: np.ndarray, directions: np.ndarray, eps: float = 1e-5) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Central differences extrapolated (4 D(eps/2) - D(eps)) / 3: error O(eps^4), for the
    stiff directions off T(S^2)^n (the rod's springs curve V strongly along q_i)."""
    return (4 * _central(f, x, directions, eps / 2) - _central(f, x, directions, eps)) / 3


def _check_differences(model: Model, name: str) -> None:
    """A (tangent and embedding) against central differences of the emitted step, relative
    agreement 1e-6 (as `test_jacobian` states it; extrapolated differences in the embedding
    coordinates)."""
    q0, w0 = _start(model)
    x0 = np.concatenate([np.ravel(q0), np.ravel(w0)])
    tan = model.linearize(q0, w0, H, name, options=EXACT)
    emb = model.linearize(q0, w0, H, name, basis="embedding", options=EXACT)
    stepped = _state_step(model, x0, name)
    assert np.allclose(np.concatenate([np.ravel(emb.q), np.ravel(emb.omega)]), stepped, 0, 1e-14)

    def f(x: np.ndarray) -> np.ndarray:
        return _state_step(model, x, name)

    scale = np.abs(emb.A).max()
    along = _central(f, x0, tan.basis_in)
    assert np.abs(tan.A - tan.basis_out.T @ along).max() <= 1e-6 * scale
    if method(name).family is Family.VI:
        assert np.abs(tan.basis_out @ tan.A - along).max() <= 1e-6 * scale
    n = model.system.n
    assert np.abs(emb.A - _richardson(f, x0, np.eye(6 * n))).max() <= 1e-6 * scale


@pytest.mark.parametrize("name", ["rk4", "vi"])
def test_chain_matches_central_differences(name: str) -> None:
    """pendulum_chain (6 bodies, max-index M solved by the structured solver, a chain term
    and a body term): rk4 and the VI."""
    _check_differences(_model("chain"), name)


@pytest.mark.parametrize("name", ["vi", "vi4", "rk4"])
def test_banded_chain_matches_central_differences(name: str) -> None:
    """A chain whose M couples neighbours only (banded, `test_chains.banded_chain`: the band
    solver's Newton): the VI, a composition and rk4."""
    if "banded" not in _MODELS:
        _MODELS["banded"] = Model(banded_chain(9, 1))
    _check_differences(_MODELS["banded"], name)


@pytest.mark.parametrize(
    ("key", "name"), [("dipoles", "vi"), ("dipoles", "rk4"), ("rod", "vi"), ("rod", "rk4")]
)
def test_large_systems_match_central_differences(key: str, name: str) -> None:
    """The 16 dipoles (all pair blocks from one 6 x 6 kernel) and the 10-body rod with a dense
    M (every pair of M coupled): vi and rk4."""
    _check_differences(_model(key), name)


@pytest.mark.parametrize("key", ["dipoles", "rod"])
def test_large_vi_jacobian_is_symplectic(key: str) -> None:
    """A^T J(x+) A = J(x) to 1e-12 for the closed VI on the dipoles and the rod, J the
    canonical form in the tangent bases; rk4's A does not preserve it (the test can fail).
    h = 0.01: at 0.05 the rod's VI step is beyond its stability (|A| about 1e5), where the
    products lose the digits the check needs."""
    model = _model(key)
    q0, w0 = _start(model)
    for meth, exact in (("vi", True), ("rk4", False)):
        lin = model.linearize(q0, w0, H, meth, options=EXACT)
        j_in = _symplectic_form(model, q0, w0, lin.basis_in)
        j_out = _symplectic_form(model, lin.q, lin.omega, lin.basis_out)
        err = np.abs(lin.A.T @ j_out @ lin.A - j_in).max() / np.abs(j_in).max()
        assert bool(err < 1e-12) == exact, (meth, err)


def _corner_system() -> Model:
    """Three bodies whose M_13 = eps m is zero at the spec (eps = 0) but moves with eps: the
    pair the step skips must still enter dx+/d(eps)."""
    m, eps, g = (sp.Symbol(s, real=True) for s in ("m", "eps", "g"))
    M = sp.Matrix([[3 * m, m, eps * m], [m, 2 * m, m / 2], [eps * m, m / 2, m]])
    V = g * sum(q_symbol(i, 2) for i in (1, 2, 3))
    q0 = np.array([[0.6, 0.0, -0.8], [0.0, 0.6, -0.8], [0.48, 0.36, -0.8]])
    w0 = np.cross(q0, [[0.3, -0.2, 0.1], [0.1, 0.4, 0.0], [-0.2, 0.1, 0.3]])
    s = System.create(
        name="corner",
        n=3,
        parameters={"m": 1.0, "eps": 0.0, "g": 9.81},
        inertia=M,
        potential=V,
        q0=q0,
        omega0=w0,
    )
    return Model(s)


@pytest.mark.parametrize("name", ["vi", "rk4"])
def test_parameter_jacobian_of_an_entry_zero_at_the_spec(name: str) -> None:
    """P against central differences in each parameter (relative 1e-6) where an entry of M
    vanishes at the spec values but not its derivative in a parameter."""
    if "corner" not in _MODELS:
        _MODELS["corner"] = _corner_system()
    model = _MODELS["corner"]
    s = model.system
    q0, w0 = np.asarray(s.q0, float), np.asarray(s.omega0, float)
    P = model.linearize(q0, w0, H, name, basis="embedding", options=EXACT).P
    base = dict(zip(s.parameter_names, s.parameter_values))
    for k, pname in enumerate(s.parameter_names):
        eps = 1e-6
        ends = [
            np.concatenate(
                [
                    np.ravel(x)
                    for x in model.step(
                        q0, w0, H, name, EXACT, params={**base, pname: base[pname] + sign * eps}
                    )
                ]
            )
            for sign in (1, -1)
        ]
        fd = (ends[0] - ends[1]) / (2 * eps)
        assert np.abs(fd).max() > 0
        assert np.abs(P[:, k] - fd).max() <= 1e-6 * np.abs(fd).max(), (pname, k)
