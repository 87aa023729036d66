"""The step Jacobians (step_jacobian() in C, `Model.linearize`) against independent answers:
central finite differences of the emitted step (here only: the Jacobians themselves take
none), the symplecticity of the VI's derivative in the canonical form written from M, and the
eigenvalues at the double pendulum's hanging equilibrium from the closed form of its
linearized normal modes (computed here from M and V with NumPy)."""

from __future__ import annotations

import ctypes
from fractions import Fraction

import numpy as np
import pytest
from docs_text import code_blocks, page

from s2gen import load
from s2gen.methods import Family, method
from s2gen.runtime.c import CBackend, contiguous, pointer
from s2gen.runtime.linearize import frame, tangent_basis
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.tableaus import Explicit

#: Steps through the emitted code exactly from the state given (no unit check, tight Newton)
EXACT = Options(unit_tol=0.0, newton_tol=1e-15)
H = 0.01


@pytest.fixture(scope="module")
def ring() -> Model:
    """Driven, an input in V as well as in the forces (dV/dq depends on u)."""
    return Model(load("tests/specs/driven_ring.toml"))


@pytest.fixture(scope="module")
def forced() -> Model:
    """Driven, its M max-index (the structured solver's VI)."""
    return Model(load("forced_double_pendulum"))


def _state(model: Model) -> np.ndarray:
    s = model.system
    return np.concatenate([np.ravel(s.q0), np.ravel(s.omega0)])


def _step(model: Model, x: np.ndarray, name: str, t: float, u: np.ndarray | None) -> np.ndarray:
    n = model.system.n
    q, w = model.step(x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), H, name, EXACT, t=t, u=u)
    return np.concatenate([np.ravel(q), np.ravel(w)])


def _central(f, x: np.ndarray, directions: np.ndarray, eps: float = 1e-5) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Central differences of f at x along the columns of `directions`."""
    return np.array([(f(x + eps * d) - f(x - eps * d)) / (2 * eps) for d in directions.T]).T


CASES = [
    ("double", "rk4"),
    ("double", "vi"),
    ("double", "vi4"),
    ("four", "vi"),
    ("four", "rk2-proj"),
    ("driven", "rk4"),
    ("driven", "vi"),
    ("driven", "vi6"),
    ("forced", "vi"),
    ("forced", "rk4"),
    ("ring", "vi"),
    ("ring", "rk4"),
]


@pytest.mark.parametrize(("fixture", "name"), CASES)
def test_jacobians_match_central_differences(
    fixture: str, name: str, request: pytest.FixtureRequest
) -> None:
    """A in the tangent basis and in the embedding coordinates, and B, against central
    differences of the emitted step along the tangent basis, the 6n coordinates and the
    inputs: relative agreement 1e-6 (the differences' own error is about 1e-9). A Runge-Kutta
    step leaves T(S^2)^n by its local error, so its tangent A is the derivative projected on
    the tangent space after the step; the VI's loses nothing."""
    model: Model = request.getfixturevalue(fixture)
    s = model.system
    n, ni = s.n, len(s.inputs.names)
    x0, t = _state(model), 0.3
    u = np.array(s.inputs.values, dtype=float) + 0.1 if ni else None
    q0, w0 = x0[: 3 * n].reshape(n, 3), x0[3 * n :].reshape(n, 3)
    tan = model.linearize(q0, w0, H, name, t=t, u=u, options=EXACT)
    emb = model.linearize(q0, w0, H, name, t=t, u=u, basis="embedding", options=EXACT)
    assert np.array_equal(tan.q, emb.q) and np.array_equal(tan.omega, emb.omega)
    stepped = _step(model, x0, name, t, u)
    assert np.allclose(np.concatenate([np.ravel(emb.q), np.ravel(emb.omega)]), stepped, 0, 1e-14)

    def f(x: np.ndarray) -> np.ndarray:
        return _step(model, x, name, t, u)

    scale = np.abs(emb.A).max()
    along = _central(f, x0, tan.basis_in)
    assert np.abs(tan.A - tan.basis_out.T @ along).max() <= 1e-6 * scale
    if method(name).family is Family.VI:
        # the VI keeps T(S^2)^n: tangent displacements stay tangent, nothing is projected away
        assert np.abs(tan.basis_out @ tan.A - along).max() <= 1e-6 * scale
    assert np.abs(emb.A - _central(f, x0, np.eye(6 * n))).max() <= 1e-6 * scale
    if ni:
        assert u is not None

        def g(v: np.ndarray) -> np.ndarray:
            return _step(model, x0, name, t, v)

        fd = _central(g, u, np.eye(ni))
        assert np.abs(emb.B - fd).max() <= 1e-6 * np.abs(fd).max()
        assert np.allclose(tan.B, tan.basis_out.T @ emb.B, 0, 1e-15)


def test_tangent_basis_is_orthonormal_and_tangent() -> None:
    """The basis at a state with w . q = 0 is orthonormal and spans the tangent space of
    T(S^2)^n: q_i . dq_i = 0 and q_i . dw_i + w_i . dq_i = 0 for every column."""
    rng = np.random.default_rng(3)
    q = rng.normal(size=(3, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = np.cross(q, rng.normal(size=(3, 3)))
    E = tangent_basis(q, w)
    assert np.allclose(E.T @ E, np.eye(12), 0, 1e-14)
    dq, dw = E[:9].reshape(3, 3, 12), E[9:].reshape(3, 3, 12)
    assert np.abs(np.einsum("ic,ick->ik", q, dq)).max() < 1e-15
    assert np.abs(np.einsum("ic,ick->ik", q, dw) + np.einsum("ic,ick->ik", w, dq)).max() < 1e-14
    fr = frame(q)
    assert np.allclose(np.cross(fr[:, :, 0], fr[:, :, 1]), q, 0, 1e-14)


def _symplectic_form(model: Model, q: np.ndarray, w: np.ndarray, E: np.ndarray) -> np.ndarray:
    """sigma(e_a, e_b) for the columns of E at (q, w): sigma = sum_i dP_i ^ dq_i with
    P_i = sum_j M_ij w_j x q_j (the momentum of L = 1/2 sum M_ij qdot_i . qdot_j)."""
    s = model.system
    n = s.n
    M = s.inertia_numeric()
    dq, dw = E[: 3 * n].reshape(n, 3, -1), E[3 * n :].reshape(n, 3, -1)
    dP = np.zeros_like(dq)
    for i in range(n):
        for j in range(n):
            dP[i] += M[i, j] * (
                np.cross(dw[j], q[j], axis=0) + np.cross(w[j][:, None], dq[j], axis=0)
            )
    dP_flat, dq_flat = dP.reshape(3 * n, -1), dq.reshape(3 * n, -1)
    return dP_flat.T @ dq_flat - dq_flat.T @ dP_flat


@pytest.mark.parametrize(("fixture", "name"), [("double", "vi"), ("double", "vi4"), ("four", "vi")])
def test_vi_jacobian_is_symplectic(fixture: str, name: str, request: pytest.FixtureRequest) -> None:
    """A^T J(x+) A = J(x) to 1e-12 for the closed VI, J the canonical form in the tangent
    bases; RK4's A does not preserve it (the test can fail)."""
    model: Model = request.getfixturevalue(fixture)
    s = model.system
    q0, w0 = np.asarray(s.q0, float), np.asarray(s.omega0, float)
    for meth, exact in ((name, True), ("rk4", False)):
        lin = model.linearize(q0, w0, 0.05, meth, options=EXACT)
        j_in = _symplectic_form(model, q0, w0, lin.basis_in)
        j_out = _symplectic_form(model, lin.q, lin.omega, lin.basis_out)
        err = np.abs(lin.A.T @ j_out @ lin.A - j_in).max() / np.abs(j_in).max()
        assert bool(err < 1e-12) == exact, (meth, err)


def _verlet(fractions: tuple[Fraction, ...], h: float, omega: float) -> np.ndarray:
    """The velocity Verlet step of x'' = -omega^2 x (unit mass) composed over the substeps."""
    out = np.eye(2)
    for fr in fractions:
        s = float(fr) * h
        c = 1 - (s * omega) ** 2 / 2
        out = np.array([[c, s], [-s * omega**2 * (1 - (s * omega) ** 2 / 4), c]]) @ out
    return out


def _rk_amplification(t: Explicit, z: complex) -> complex:
    """R(z) of an explicit tableau: the step of y' = lambda y, z = h lambda."""
    k: list[complex] = []
    for i in range(len(t.b)):
        y = 1 + z * sum(float(a) * k[j] for j, a in enumerate(t.a[i]))
        k.append(y)
    return 1 + z * sum(float(b) * kj for b, kj in zip(t.b, k))


@pytest.mark.parametrize("name", ["rk4", "vi", "vi4"])
def test_hanging_equilibrium_eigenvalues(double: Model, name: str) -> None:
    """At the hanging equilibrium (q_i = e_z, w = 0: e_z points down), the normal modes of
    M_t a'' = -K a (M_t = M (x) I_2 in the tangent frames, K_ii = -(g_i . q_i) I_2 for V linear
    in q) have frequencies omega_k; A's eigenvalues are R(+-i omega_k h) for a Runge-Kutta
    method and, for the VI, those of the velocity Verlet step of each mode (the VI's
    linearization there), composed over the substeps: all from NumPy, not from the code."""
    s = double.system
    n, h = s.n, 0.05
    q0 = np.tile([0.0, 0.0, 1.0], (n, 1))
    w0 = np.zeros((n, 3))
    p = dict(zip(s.parameter_names, s.parameter_values))
    # V = -(m1 + m2) g l1 q1_z - m2 g l2 q2_z: gradient g_i = -k_i e_z, -g_i . q_i = k_i
    k = np.array([(p["m1"] + p["m2"]) * p["g"] * p["l1"], p["m2"] * p["g"] * p["l2"]])
    omegas = np.sqrt(np.linalg.eigvals(np.linalg.solve(s.inertia_numeric(), np.diag(k))).real)
    row = method(name)
    if row.tableau is not None:
        expected = [
            _rk_amplification(row.tableau, sg * 1j * om * h) for om in omegas for sg in (1, -1)
        ]
    else:
        assert row.composition is not None
        expected = [
            ev
            for om in omegas
            for ev in np.linalg.eigvals(_verlet(row.composition.fractions, h, om))
        ]
    lin = double.linearize(q0, w0, h, name, options=EXACT)
    got = list(np.linalg.eigvals(lin.A))
    assert len(got) == 2 * len(expected)  # two polarizations of each mode
    for ev in expected * 2:
        nearest = min(range(len(got)), key=lambda i: abs(got[i] - ev))
        assert abs(got.pop(nearest) - ev) < 1e-9, (ev, got)


def test_linearize_refuses_in_one_line(double: Model) -> None:
    s = double.system
    with pytest.raises(ValueError, match="method 'rk45' has no step Jacobian"):
        double.linearize(s.q0, s.omega0, H, "rk45")
    with pytest.raises(ValueError, match="basis 'polar'"):
        double.linearize(s.q0, s.omega0, H, "vi", basis="polar")
    reference = Model(s, "reference")  # its Jacobians: tests/test_reference_jvp_field.py
    with pytest.raises(ValueError, match="fixed-step methods vi, .*not 'rk45'"):
        reference.linearize(s.q0, s.omega0, H, "rk45")


def test_docs_linearization_block(double: Model) -> None:
    """The block of docs/user_guide/linearization.rst (the README's "Linearization" section
    before it moved), run as it stands: the image it computes of a tangent displacement agrees
    with central differences of the emitted VI step."""
    code = code_blocks(page("user_guide/linearization.rst"), "python")[0]
    ns: dict[str, object] = {}
    exec(compile(code, "linearization.rst", "exec"), ns)  # noqa: S102 (the page's own example)
    lin, emb, dx, after = ns["lin"], ns["emb"], ns["dx"], ns["after"]
    assert lin.A.shape == (8, 8) and emb.A.shape == (12, 12)  # type: ignore[attr-defined]
    x0 = _state(double)
    fd = (
        _step(double, x0 + 100 * dx, "vi", 0.0, None)
        - _step(double, x0 - 100 * dx, "vi", 0.0, None)
    ) / 200  # type: ignore[operator]
    assert np.abs(after - fd).max() < 1e-6 * np.abs(fd).max()  # type: ignore[operator]


P_CASES = [
    ("double", "rk4"),
    ("double", "vi"),
    ("double", "vi4"),
    ("driven", "rk4"),
    ("driven", "vi"),
    ("four", "vi"),
    ("four", "rk2-proj"),
    ("forced", "vi"),
    ("ring", "vi"),
]


@pytest.mark.parametrize(("fixture", "name"), P_CASES)
def test_parameter_jacobian_matches_central_differences(
    fixture: str, name: str, request: pytest.FixtureRequest
) -> None:
    """P = dx+/dp (embedding and tangent) against central differences of the emitted step in
    each parameter (relative step 1e-6), relative agreement 1e-6: the masses and lengths enter
    M (m l^2) and V, g enters V, the driven pendulum's parameters its forces too."""
    model: Model = request.getfixturevalue(fixture)
    s = model.system
    n, ni = s.n, len(s.inputs.names)
    x0, t = _state(model), 0.3
    u = np.array(s.inputs.values, dtype=float) + 0.1 if ni else None
    q0, w0 = x0[: 3 * n].reshape(n, 3), x0[3 * n :].reshape(n, 3)
    emb = model.linearize(q0, w0, H, name, t=t, u=u, basis="embedding", options=EXACT)
    tan = model.linearize(q0, w0, H, name, t=t, u=u, options=EXACT)
    assert emb.P.shape == (6 * n, len(s.parameter_names))
    base = dict(zip(s.parameter_names, s.parameter_values))
    fd = np.zeros_like(emb.P)
    for k, pname in enumerate(s.parameter_names):
        eps = 1e-6 * max(abs(base[pname]), 1.0)
        ends = []
        for sign in (1, -1):
            q, w = model.step(
                q0, w0, H, name, EXACT, params={**base, pname: base[pname] + sign * eps}, t=t, u=u
            )
            ends.append(np.concatenate([np.ravel(q), np.ravel(w)]))
        fd[:, k] = (ends[0] - ends[1]) / (2 * eps)
    scale = np.abs(fd).max()
    assert scale > 0
    assert np.abs(emb.P - fd).max() <= 1e-6 * scale, np.abs(emb.P - fd).max() / scale
    assert np.allclose(tan.P, tan.basis_out.T @ emb.P, 0, 1e-15)


def _columns(backend: CBackend, name: str, with_b: bool, with_p: bool) -> tuple:  # type: ignore[type-arg]
    """step_jacobian() from the spec's state moved off its initial values (t = 0.3, u + 0.1),
    B and P passed or NULL: (A, B or None, P or None), in the embedding coordinates."""
    s = backend.system
    n, ni, npar = s.n, len(s.inputs.names), len(s.parameter_names)
    u = contiguous(np.array(s.inputs.values, dtype=float) + 0.1) if ni else None
    q0, w0 = contiguous(np.asarray(s.q0, dtype=float)), contiguous(np.asarray(s.omega0) + 0.2)
    A, B, P = (
        np.full((6 * n, 6 * n), np.nan),
        np.full((6 * n, ni), np.nan),
        np.full((6 * n, npar), np.nan),
    )
    status = backend.library.fn["step_jacobian"](
        contiguous(backend.default_params()),
        ctypes.byref(backend.library.options(EXACT)),
        method(name).code,
        ctypes.c_double(0.3),
        ctypes.c_double(H),
        pointer(u),
        q0,
        w0,
        np.empty((n, 3)),
        np.empty((n, 3)),
        A,
        pointer(B) if with_b and ni else None,
        pointer(P) if with_p and npar else None,
        np.zeros(backend.library.jacobian_work),
    )
    assert status == 0
    return A, B if with_b and ni else None, P if with_p and npar else None


@pytest.mark.parametrize(
    ("spec", "name"),
    [
        ("tests/specs/driven_double.toml", "vi"),
        ("tests/specs/driven_double.toml", "vi6"),
        ("tests/specs/driven_double.toml", "rk4"),
        ("four_pendula", "rk2-proj"),
        ("four_pendula", "vi"),
        ("double_pendulum", "vi4"),
    ],
)
def test_null_b_and_p_leave_a_and_b_unchanged(spec: str, name: str) -> None:
    """step_jacobian() computes B's and P's columns only when they are asked for: A alone, A
    and B (P NULL), A and P (B NULL) equal the columns of the call that asks for all three,
    whose A, B and P the central-difference tests above check (to rounding: 1e-13 of A's
    largest entry)."""
    backend = CBackend(load(spec).with_jacobians())
    A, B, P = _columns(backend, name, True, True)
    for with_b, with_p in ((False, False), (True, False), (False, True)):
        a, b, p = _columns(backend, name, with_b, with_p)
        tol = 1e-13 * np.abs(A).max()
        assert np.abs(a - A).max() <= tol
        if b is not None:
            assert np.abs(b - B).max() <= tol * max(1.0, np.abs(B).max() / np.abs(A).max())
        if p is not None:
            assert np.abs(p - P).max() <= tol * max(1.0, np.abs(P).max() / np.abs(A).max())
