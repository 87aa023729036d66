"""The RATTLE family's step Jacobians of driven modules (step_jacobian() for rattle, rattle4,
rattle6, rattle8 in C and NumPy: the implicit function theorem on the forced step's equations
with G = g - F and G+ = g+ - F(x+, x+ x v+), `s2gen.equations.rattle_jacobian`) against two
independent answers: the reference's complex-step derivative of its own forced RATTLE
(`s2gen.reference.step_jacobian`, no derived equation) to 1e-10 in A, B and P, and central
differences of the emitted C step along the tangent basis of T(S^2)^n, the 6n embedding
coordinates and the inputs to 1e-7. Two systems: the ring (diagonal M, forces that read w
across bodies, inputs in V and in the forces, V(q, t)) and a double pendulum with a dense M
whose input and time enter V (a driven module with forces and a coupled M has no RATTLE step,
so no Jacobian: `test_rattle_jacobian.test_driven_rattle_has_no_step_jacobian`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from s2gen import load
from s2gen.runtime.linearize import Linearization
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.system import System

#: Newton's updates below 1e-13 leave round-off; the reference's RATTLE multipliers stall near
#: 1.5e-14 (`test_reference_jacobian`)
TOL = 1e-13
EXACT = Options(unit_tol=0.0, newton_tol=TOL)
H, T = 0.01, 0.3
RING = "tests/specs/driven_ring.toml"
#: A dense M, an input and the time in V, no forces
DENSE = """
name = "driven_dense"
bodies = 2
[parameters]
m1 = 1.0
m2 = 0.7
l1 = 1.0
l2 = 0.8
g = 9.81
a = 0.5
[inputs]
push = 0.2
[inertia]
M = [["(m1+m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]]
[potential]
V = "(m1+m2)*g*l1*q1[2] + m2*g*l2*q2[2] + a*cos(2*t)*q1[0] + push*q2[1]*q1[0]"
[initial]
q = [[0.6, 0.0, 0.8], [0.0, 0.6, 0.8]]
omega = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
"""
SPECS = {"ring": RING, "dense": DENSE}
_MODELS: dict[tuple[str, str], Model] = {}


def _system(key: str) -> System:
    return load(SPECS[key])


def _model(key: str, backend: str) -> Model:
    if (key, backend) not in _MODELS:
        _MODELS[key, backend] = Model(_system(key), backend=backend)
    return _MODELS[key, backend]


def _start(key: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The spec's state with every velocity turned by a tangent body-dependent amount, and
    the inputs moved off their defaults."""
    s = _system(key)
    q = np.asarray(s.q0, float)
    w = np.asarray(s.omega0, float) + np.cross(q, np.random.default_rng(5).normal(size=q.shape))
    return q, w, np.asarray(s.inputs.values, float) + 0.1


def _rel(X: np.ndarray, Y: np.ndarray) -> float:
    """max |X - Y| relative to the spectral norm of X."""
    return float(np.abs(X - Y).max() / np.linalg.norm(X, 2))


def _columns(X: np.ndarray, Y: np.ndarray) -> float:
    """The worst column of `_rel` (each parameter's derivative on its own scale)."""
    return max(_rel(X[:, [k]], Y[:, [k]]) for k in range(X.shape[1]))


def _central(
    f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, directions: np.ndarray, eps: float
) -> np.ndarray:
    """Central differences along the columns of `directions`, extrapolated (4 D(eps/2) -
    D(eps)) / 3: with eps = 1e-3 the truncation and Newton's stopping noise stay near 1e-10."""

    def D(e: float) -> np.ndarray:
        return np.stack([(f(x + e * d) - f(x - e * d)) / (2 * e) for d in directions.T], axis=1)

    return (4 * D(eps / 2) - D(eps)) / 3


def _linearize(key: str, backend: str, name: str, basis: str) -> Linearization:
    q, w, u = _start(key)
    return _model(key, backend).linearize(q, w, H, name, t=T, u=u, basis=basis, options=EXACT)


CASES = [("ring", "rattle"), ("ring", "rattle4"), ("dense", "rattle"), ("dense", "rattle4")]


@pytest.mark.parametrize(("key", "name"), CASES)
def test_c_and_numpy_agree_with_the_reference(key: str, name: str) -> None:
    """A, B and P of the C and the NumPy module against the reference's complex step, to
    1e-10, in the tangent basis and whole in the embedding coordinates (the driven RATTLE maps
    (q, w) to (x, v) and back at every substep as the reference does), and the state after
    the step to 1e-13."""
    for basis in ("tangent", "embedding"):
        ref = _linearize(key, "reference", name, basis)
        for backend in ("c", "numpy"):
            lin = _linearize(key, backend, name, basis)
            assert lin.A.shape == ref.A.shape and lin.B.shape == ref.B.shape
            assert _rel(lin.A, ref.A) <= 1e-10, (backend, basis)
            assert _rel(lin.B, ref.B) <= 1e-10, (backend, basis)
            assert _columns(lin.P, ref.P) <= 1e-10, (backend, basis)
            assert np.abs(lin.q - ref.q).max() <= 1e-13
            assert np.abs(lin.omega - ref.omega).max() <= 1e-12


@pytest.mark.parametrize(("key", "name"), CASES)
def test_jacobians_match_central_differences_of_the_emitted_step(key: str, name: str) -> None:
    """The C's and the NumPy's A along the tangent basis (RATTLE keeps T(S^2)^n: nothing is
    projected away) and in the 6n coordinates, and B, against central differences of the
    emitted C step: relative agreement 1e-7."""
    s = _system(key)
    n, c = s.n, _model(key, "c")
    q, w, u = _start(key)
    x = np.concatenate([q.ravel(), w.ravel()])

    def step(y: np.ndarray, v: np.ndarray) -> np.ndarray:
        qn, wn = c.step(
            y[: 3 * n].reshape(n, 3), y[3 * n :].reshape(n, 3), H, name, EXACT, t=T, u=v
        )
        return np.concatenate([np.ravel(qn), np.ravel(wn)])

    tangent = _linearize(key, "c", name, "tangent")
    along = _central(lambda y: step(y, u), x, tangent.basis_in, 1e-3)
    whole = _central(lambda y: step(y, u), x, np.eye(6 * n), 1e-3)
    inputs = _central(lambda v: step(x, v), u, np.eye(len(u)), 1e-3)
    for backend in ("c", "numpy"):
        tan = _linearize(key, backend, name, "tangent")
        emb = _linearize(key, backend, name, "embedding")
        after = np.concatenate([np.ravel(emb.q), np.ravel(emb.omega)])
        assert np.abs(after - step(x, u)).max() <= 1e-13
        assert _rel(tan.basis_out @ tan.A, along) <= 1e-7, backend
        assert _rel(emb.A, whole) <= 1e-7, backend
        assert _rel(emb.B, inputs) <= 1e-7, backend
