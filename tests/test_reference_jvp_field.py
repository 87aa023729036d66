"""The reference backend's step_jvp, field Jacobian and Lyapunov spectrum, each a complex-step
derivative through the reference's own step or field (`s2gen.reference.step_jacobian`,
`s2gen.reference.field_jacobian`), checked against independent derivations: the emitted C's
step_jvp() and field_jacobian() (derived symbolically by the generator), central differences
of the reference field, and the C's Lyapunov spectrum. Every case takes well under a second
once the C modules are built (the file runs in 10 to 15 s on 2 cores with a warm cache)."""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np
import pytest
from docs_text import code_blocks, page, section

from s2gen import load
from s2gen.cli import main
from s2gen.reference.forced import driven_rhs
from s2gen.reference.step_jacobian import _problem
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.runtime.reference_backend import ReferenceBackend

#: Newton's last update below 1e-13: round-off in the step and its complex-step derivative
EXACT = Options(unit_tol=0.0, newton_tol=1e-13)
H = 0.01
T = 0.3
DRIVEN = "tests/specs/driven_double.toml"  # coupled M, velocity-dependent forces, V(q, t), an input
SPECS = ["double_pendulum", "rope:n=6", "dipoles", DRIVEN]
_MODELS: dict[tuple[str, str], Model] = {}


def _model(spec: str, backend: str) -> Model:
    if (spec, backend) not in _MODELS:
        _MODELS[spec, backend] = Model(load(spec), backend=backend)
    return _MODELS[spec, backend]


def _start(spec: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The spec's initial state with every velocity turned by a body-dependent amount (kept
    tangent) and the inputs moved off their defaults."""
    s = load(spec)
    q = np.asarray(s.q0, float)
    w = np.asarray(s.omega0, float) + np.cross(q, np.random.default_rng(5).normal(size=q.shape))
    u = np.asarray(s.inputs.values, float) + 0.1 if s.inputs.names else None
    return q, w, u


def _direction(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A tangent direction: dq_i perpendicular to q_i, dw arbitrary (also off the tangent
    space: the embedding A is defined on all of R^6n)."""
    rng = np.random.default_rng(7)
    return np.cross(q, rng.normal(size=q.shape)), rng.normal(size=q.shape)


def _rel(X: np.ndarray, Y: np.ndarray) -> float:
    """max |X - Y| over the entries, relative to the largest entry of X (0 for no entries)."""
    if X.size == 0:
        return 0.0
    return float(np.abs(X - Y).max() / np.abs(X).max())


def _columns(X: np.ndarray, Y: np.ndarray) -> float:
    """The worst column's max |X - Y| relative to the column's largest entry (each parameter's
    derivative on its own scale), floored at 1e-3 of X's largest: a column that vanishes
    exactly (a parameter that cancels from the field, such as a uniform chain's mass, or a
    bending stiffness at a straight chain) holds round-off or difference noise, judged on the
    matrix's scale."""
    if X.size == 0:
        return 0.0
    floor = 1e-3 * np.abs(X).max()
    size = np.maximum(np.abs(X).max(axis=0), floor)
    return float((np.abs(X - Y).max(axis=0) / size).max())


@pytest.mark.parametrize(
    ("spec", "name"),
    [
        ("double_pendulum", "vi"),
        ("double_pendulum", "rk4"),
        ("rope:n=6", "vi"),
        ("dipoles", "vi"),
        (DRIVEN, "vi"),
        (DRIVEN, "rk4"),
        (DRIVEN, "rattle"),
    ],
)
def test_reference_step_jvp_is_its_jacobian_times_the_direction(spec: str, name: str) -> None:
    """The reference's step_jvp along (dq, dw) (one complex step along the direction) is its
    embedding A (6n complex steps along the coordinate axes) times the direction, to 1e-12
    relative, at time t with the inputs held; the state after the step is the step's."""
    q, w, u = _start(spec)
    dq, dw = _direction(q)
    ref = _model(spec, "reference")
    st = ref.step_jvp(q, w, H, dq, dw, name, options=EXACT, t=T, u=u)
    lin = ref.linearize(q, w, H, name, t=T, u=u, basis="embedding", options=EXACT)
    Av = lin.A @ np.concatenate([dq.ravel(), dw.ravel()])
    assert _rel(Av, np.concatenate([st.dq.ravel(), st.domega.ravel()])) <= 1e-12
    assert np.array_equal(st.q, lin.q) and np.array_equal(st.omega, lin.omega)


@pytest.mark.parametrize(
    ("spec", "name"),
    [("rope:n=12", "vi"), ("rope:n=12", "rk4"), ("dipoles", "vi"), ("dipoles", "rk2-proj")],
)
def test_reference_step_jvp_matches_the_emitted_one(spec: str, name: str) -> None:
    """The reference's step_jvp and the C's step_jvp() (the structured chain's O(n) product,
    the dipoles' diagonal M) agree to 1e-12 relative, and so do their steps."""
    q, w, _ = _start(spec)
    dq, dw = _direction(q)
    c = _model(spec, "c").step_jvp(q, w, H, dq, dw, name, options=EXACT)
    ref = _model(spec, "reference").step_jvp(q, w, H, dq, dw, name, options=EXACT)
    assert _rel(np.hstack([c.dq, c.domega]), np.hstack([ref.dq, ref.domega])) <= 1e-12
    assert _rel(c.q, ref.q) <= 1e-14 and _rel(c.omega, ref.omega) <= 1e-13


@pytest.mark.parametrize("spec", SPECS)
def test_reference_field_jacobian_matches_the_emitted_one(spec: str) -> None:
    """J, Ju and Jp of the field from the reference (complex step) and from the emitted C
    (SymPy's derivatives) agree to 1e-10 relative in the embedding coordinates (whole: the two
    write the same field off the sphere too) and in the tangent coordinates, with the field."""
    q, w, u = _start(spec)
    for basis in ("embedding", "tangent"):
        c = _model(spec, "c").jacobian_field(q, w, t=T, u=u, basis=basis)
        ref = _model(spec, "reference").jacobian_field(q, w, t=T, u=u, basis=basis)
        assert c.J.shape == ref.J.shape and c.Ju.shape == ref.Ju.shape
        assert _rel(c.J, ref.J) <= 1e-10
        assert _rel(c.Ju, ref.Ju) <= 1e-10
        assert _columns(c.Jp, ref.Jp) <= 1e-10
        assert _rel(np.hstack([c.qdot, c.wdot]), np.hstack([ref.qdot, ref.wdot])) <= 1e-13
        assert np.array_equal(c.basis_at, ref.basis_at)


def _central(
    f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, directions: np.ndarray, eps: float
) -> np.ndarray:
    """Central differences of f at x along the columns of `directions`, extrapolated
    (4 D(eps/2) - D(eps)) / 3 (error O(eps^4))."""

    def D(e: float) -> np.ndarray:
        cols = [(f(x + e * d) - f(x - e * d)) / (2 * e) for d in directions.T]
        return np.stack(cols, axis=1) if cols else np.zeros((len(f(x)), 0))

    return (4 * D(eps / 2) - D(eps)) / 3


@pytest.mark.parametrize("spec", SPECS)
def test_reference_field_jacobian_matches_central_differences(spec: str) -> None:
    """The reference's J (embedding, every column), Ju and Jp against central differences of
    the reference field itself (`driven_rhs`, the field its Runge-Kutta steps evaluate):
    relative agreement 1e-7 (Jp column by column, `_columns`)."""
    s = load(spec)
    q, w, u0 = _start(spec)
    n, ni = s.n, len(s.inputs.names)
    u = np.zeros(0) if u0 is None else u0
    p = np.asarray(s.parameter_values, float)
    fj = _model(spec, "reference").jacobian_field(q, w, t=T, u=u0, basis="embedding")
    problem = _problem(s, p)

    def field(x: np.ndarray, v: np.ndarray, pr: object = problem) -> np.ndarray:
        qd, wd = driven_rhs(pr, T, x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), v)  # type: ignore[arg-type]
        return np.concatenate([qd.ravel(), wd.ravel()])

    x = np.concatenate([q.ravel(), w.ravel()])
    assert np.array_equal(field(x, u), np.concatenate([fj.qdot.ravel(), fj.wdot.ravel()]))
    assert _rel(fj.J, _central(lambda y: field(y, u), x, np.eye(6 * n), 1e-3)) <= 1e-7
    assert _rel(fj.Ju, _central(lambda v: field(x, v), u, np.eye(ni), 1e-3)) <= 1e-7
    scale = np.where(p != 0.0, np.abs(p), 1.0)  # each parameter stepped by 1e-3 of its size
    fd = _central(lambda pp: field(x, u, _problem(s, pp)), p, np.diag(scale), 1e-3) / scale
    assert _columns(fj.Jp, fd) <= 1e-7


def test_reference_lyapunov_matches_the_emitted_one() -> None:
    """The double pendulum's VI spectrum over T = 1 after a transient of 0.2, from the
    reference's complex-step A and from the C's step_jacobian(): the exponents agree to 1e-9
    (the products of 120 Jacobians, each agreeing to about 1e-13)."""
    s = load("double_pendulum")
    args = (s.q0, s.omega0, H, 1.0, "vi", 0.2)
    c = _model("double_pendulum", "c").lyapunov(*args, options=EXACT)
    ref = _model("double_pendulum", "reference").lyapunov(*args, options=EXACT)
    assert np.abs(c.exponents - ref.exponents).max() <= 1e-9
    assert np.abs(c.running - ref.running).max() <= 1e-9


def test_reference_lyapunov_names_the_failed_step() -> None:
    """A Newton failure in a later step of the reference's Lyapunov run is a one-line
    ValueError with the status and the step's time (the first step's goes through linearize)."""
    s = load("double_pendulum")
    few = Options(newton_maxiter=4)  # enough for the first steps from the spec's state, not all
    with pytest.raises(ValueError, match=r"ERR_NEWTON: .* \(the step at t = 0\.15\)$"):
        _model("double_pendulum", "reference").lyapunov(
            s.q0, s.omega0, 0.05, 2.0, "vi", blocks=2, options=few
        )


def test_step_jvp_refuses_the_numpy_backend() -> None:
    """The NumPy backend has no step_jvp: one line naming the backends that do."""
    s = load("double_pendulum")
    with pytest.raises(TypeError, match="C and reference backends, not 'numpy'"):
        _model("double_pendulum", "numpy").step_jvp(s.q0, s.omega0, H, s.q0, s.omega0)


def test_lyapunov_command_on_the_reference_backend(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """`s2gen lyapunov --backend reference` prints the spectrum of the reference's
    complex-step Jacobians (every step after the first through them): the C's exponents
    (Model.lyapunov on the C backend) to the printed digits."""
    calls = []
    state_jacobian = ReferenceBackend.state_jacobian

    def counted(self: ReferenceBackend, *args: object) -> tuple[np.ndarray, ...]:
        calls.append(args[1])
        return state_jacobian(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(ReferenceBackend, "state_jacobian", counted)
    args = ["double_pendulum", "--T", "0.5", "--transient", "0.1", "--no-progress"]
    assert main(["lyapunov", *args, "--backend", "reference"]) == 0
    assert len(calls) == 59  # 60 steps of h = 0.01, the first through linearize
    text = capsys.readouterr().out
    exponent = re.compile(r"^  lambda_\d+ +([+-][0-9.]+) \+- ", re.MULTILINE)
    printed = [float(x) for x in exponent.findall(text)]
    s = load("double_pendulum")
    c = _model("double_pendulum", "c").lyapunov(s.q0, s.omega0, H, 0.5, "vi", 0.1)
    assert len(printed) == 8 and np.allclose(printed, c.exponents, rtol=0, atol=6e-7)


def test_docs_reference_field_and_jvp_block() -> None:
    """The two blocks of docs/user_guide/linearization.rst's section on the reference's
    Jacobian, run in turn as they stand: the field Jacobian is the C's (1e-10), and the product
    is the C's embedding A (vi) times the tangent direction (1e-10)."""
    text = section(
        page("user_guide/linearization.rst"), "The reference's Jacobian: an independent check"
    )
    ns: dict[str, object] = {}
    for block in code_blocks(text, "python")[:2]:
        exec(compile(block, "linearization.rst", "exec"), ns)  # noqa: S102
    s = load("double_pendulum")
    fj, st, dq = ns["fj"], ns["st"], ns["dq"]
    c = _model("double_pendulum", "c")
    assert _rel(c.jacobian_field(s.q0, s.omega0).J, fj.J) <= 1e-10  # type: ignore[attr-defined]
    lin = c.linearize(s.q0, s.omega0, 0.01, "vi", basis="embedding")
    Av = lin.A @ np.concatenate([np.ravel(dq), np.zeros(3 * s.n)])  # type: ignore[arg-type]
    got = np.concatenate([st.dq.ravel(), st.domega.ravel()])  # type: ignore[attr-defined]
    assert _rel(Av, got) <= 1e-10
