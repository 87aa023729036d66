"""The continuous field's Jacobian (field_jacobian() in C, `Model.jacobian_field`) against
central finite differences of the emitted field (the RHS the Runge-Kutta methods call, or a
driven module's field_at()), the step Jacobian's first order in h (A = I + hJ + O(h^2), with
the order measured), and the basis' rate against differences of the basis."""

from __future__ import annotations

import ctypes
import itertools

import numpy as np
import pytest

from s2gen.equations.jacobian import JACOBIAN_MAX_BODIES
from s2gen.runtime.field_jacobian import basis_rate
from s2gen.runtime.linearize import tangent_basis
from s2gen.runtime.model import Model
from s2gen.systems import builtin


def _field(model: Model, t: float, u: np.ndarray | None, p: np.ndarray | None = None):  # type: ignore[no-untyped-def]
    """x -> (qdot, wdot) of the emitted C: rhs() of a closed module, field_at() of a driven
    one (the functions the integrators call, not field_jacobian()), with the parameters p
    (None: the spec's)."""
    n = model.system.n
    backend = model._backend
    p = model.params() if p is None else np.ascontiguousarray(p, dtype=float)
    if not model.system.driven:

        def closed(x: np.ndarray) -> np.ndarray:
            dq, dw = backend.rhs(x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), p)
            return np.concatenate([np.ravel(dq), np.ravel(dw)])

        return closed
    fn = backend.library.fn["field_at"]
    work = np.zeros_like(backend.library.work)
    up = None if u is None else u.ctypes.data

    def driven(x: np.ndarray) -> np.ndarray:
        q, w = np.ascontiguousarray(x[: 3 * n]), np.ascontiguousarray(x[3 * n :])
        dq, dw = np.empty(3 * n), np.empty(3 * n)
        assert fn(p, ctypes.c_double(t), up, q, w, dq, dw, work) == 0
        return np.concatenate([dq, dw])

    return driven


def _central(f, x: np.ndarray, directions: np.ndarray, eps: float = 1e-6) -> np.ndarray:  # type: ignore[no-untyped-def]
    return np.array([(f(x + eps * d) - f(x - eps * d)) / (2 * eps) for d in directions.T]).T


@pytest.mark.parametrize("fixture", ["double", "four", "driven"])
def test_field_jacobian_matches_central_differences(
    fixture: str, request: pytest.FixtureRequest
) -> None:
    """J along the tangent basis and Ju against central differences of the emitted field at a
    moving state (relative 1e-7; the differences' own error is about 1e-10), and the field
    returned with J is the emitted field itself."""
    model: Model = request.getfixturevalue(fixture)
    s = model.system
    ni = len(s.inputs.names)
    t = 0.3
    u = np.array(s.inputs.values, dtype=float) + 0.1 if ni else None
    q0, w0 = np.asarray(s.q0, dtype=float), np.asarray(s.omega0, dtype=float)
    x0 = np.concatenate([np.ravel(q0), np.ravel(w0)])
    f = _field(model, t, u)
    fj = model.jacobian_field(q0, w0, t=t, u=u, basis="embedding")
    assert np.array_equal(np.concatenate([np.ravel(fj.qdot), np.ravel(fj.wdot)]), f(x0))
    E = tangent_basis(q0, w0)
    along = _central(f, x0, E)
    scale = np.abs(along).max()
    assert np.abs(fj.J @ E - along).max() <= 1e-7 * scale
    if ni:
        assert u is not None

        def g(v: np.ndarray) -> np.ndarray:
            return _field(model, t, v)(x0)

        fd = _central(g, u, np.eye(ni))
        assert np.abs(fj.Ju - fd).max() <= 1e-7 * np.abs(fd).max()
        tan = model.jacobian_field(q0, w0, t=t, u=u)
        assert np.allclose(tan.Ju, E.T @ fj.Ju, 0, 1e-15)
    # Jp: each parameter moved by a relative 1e-6 (they enter M, V and the forces)
    p0 = model.params()
    steps = 1e-6 * np.maximum(np.abs(p0), 1.0)
    fd_p = np.array(
        [
            (_field(model, t, u, p0 + dp)(x0) - _field(model, t, u, p0 - dp)(x0)) / (2 * e)
            for dp, e in ((np.eye(len(p0))[k] * steps[k], steps[k]) for k in range(len(p0)))
        ]
    ).T
    assert fj.Jp.shape == (6 * s.n, len(p0))
    assert np.abs(fj.Jp - fd_p).max() <= 1e-7 * np.abs(fd_p).max()


@pytest.mark.parametrize(("fixture", "basis"), [("double", "tangent"), ("double", "embedding"),
                                                ("driven", "tangent"), ("driven", "embedding")])  # fmt: skip
def test_rk4_step_jacobian_is_identity_plus_h_field_jacobian(
    fixture: str, basis: str, request: pytest.FixtureRequest
) -> None:
    """A(h) - I - h J = O(h^2) for RK4's step (and B(h) - h Ju): the error falls by 4 (3.6
    to 4.4) when h halves, in the embedding and, with the basis' rate term, in the tangent
    coordinates (without it the tangent error would be O(h))."""
    model: Model = request.getfixturevalue(fixture)
    s = model.system
    ni = len(s.inputs.names)
    t = 0.3
    u = np.array(s.inputs.values, dtype=float) + 0.1 if ni else None
    fj = model.jacobian_field(s.q0, s.omega0, t=t, u=u, basis=basis)
    errors, input_errors = [], []
    for h in (4e-3, 2e-3, 1e-3):
        lin = model.linearize(s.q0, s.omega0, h, "rk4", t=t, u=u, basis=basis)
        errors.append(np.abs(lin.A - np.eye(len(lin.A)) - h * fj.J).max())
        if ni:
            input_errors.append(np.abs(lin.B - h * fj.Ju).max())
    for e in (errors, input_errors):
        for coarse, fine in itertools.pairwise(e):
            assert 3.6 <= coarse / fine <= 4.4, e


def test_basis_rate_matches_differences_of_the_basis() -> None:
    """basis_rate against central differences of tangent_basis along a tangent (dq, dw)."""
    rng = np.random.default_rng(5)
    q = rng.normal(size=(3, 3))
    q[:, 0] = np.abs(q[:, 0])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = np.cross(q, rng.normal(size=(3, 3)))
    dq = np.cross(q, rng.normal(size=(3, 3)))
    dw = rng.normal(size=(3, 3))
    eps = 1e-6
    fd = (tangent_basis(q + eps * dq, w + eps * dw) - tangent_basis(q - eps * dq, w - eps * dw)) / (
        2 * eps
    )
    assert np.abs(basis_rate(q, w, dq, dw) - fd).max() <= 1e-8


def test_field_jacobian_refuses_bad_input(double: Model) -> None:
    s = double.system
    with pytest.raises(ValueError, match="basis 'polar'"):
        double.jacobian_field(s.q0, s.omega0, basis="polar")
    with pytest.raises(ValueError, match="ERR_NONFINITE"):
        double.jacobian_field(np.full((2, 3), np.nan), s.omega0)
    big = builtin("rope", n=JACOBIAN_MAX_BODIES + 1)
    with pytest.raises(ValueError, match=f"at most {JACOBIAN_MAX_BODIES} bodies"):
        Model(big).jacobian_field(big.q0, big.omega0)
