"""The NumPy module's step and field Jacobians (its step_jacobian() and field_jacobian(),
`Model.linearize` and `Model.jacobian_field` on the NumPy backend) against the C's, which
print the same derived kernels and differ only by round-off (relative agreement 1e-10, every
method with a step Jacobian, A, B, P, J, Ju, Jp), and, independently of the C, against
central differences of the NumPy step itself (A, B and P of a driven system with an input)."""

from __future__ import annotations

import numpy as np
import pytest
from docs_text import code_blocks, page, section
from test_chains import banded_chain
from test_jacobian import EXACT, _central

from s2gen import load
from s2gen.methods import METHODS, Family, driven_methods, fixed_methods, method
from s2gen.runtime.model import Model
from s2gen.system import System

H = 0.01
T0 = 0.3
#: The systems of conftest's session fixtures
FIXTURES = ("double", "four", "driven")
#: The systems NumPy and C are compared on
KEYS = ["double", "four", "driven", "dipoles", "banded", "chain"]
#: Relative agreement of the NumPy and C Jacobians (the same kernels, different round-off)
CLOSE = 1e-10


def _system(key: str, request: pytest.FixtureRequest) -> System:
    """The conftest fixtures' systems (double pendulum, four pendula joined by springs in a
    ring: pair terms whose members share bodies and curve V there, driven double pendulum
    with an input), the dipoles (a pair term over a list of pairs), a chain whose M is banded (the
    band solver's VI), the pendulum chain (max-index M) and a driven ring (diagonal M, V
    coupling the bodies, inputs in V and the forces)."""
    if key in FIXTURES:
        return request.getfixturevalue(key).system  # type: ignore[no-any-return]
    if key == "banded":
        return banded_chain(9, 1)
    specs = {
        "dipoles": "dipoles",
        "chain": "pendulum_chain",
        "ring": "tests/specs/driven_ring.toml",
    }
    return load(specs[key])


def _methods(system: System) -> list[str]:
    """Every method with a step Jacobian: the fixed-step Runge-Kutta methods and the VI
    family (a driven module's: its own), and a closed module's RATTLE family."""
    names = [m.name for m in fixed_methods("sphere")]
    names += [m.name for m in METHODS if m.family is Family.VI]
    if not system.driven:
        names += [m.name for m in METHODS if m.family is Family.RATTLE]
    return [m for m in names if not system.driven or m in driven_methods()]


def _start(system: System) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The spec's state with every velocity turned by a body-dependent tangent amount, and
    inputs off their defaults."""
    q = np.asarray(system.q0, float)
    rng = np.random.default_rng(7)
    w = np.asarray(system.omega0, float) + np.cross(q, rng.normal(scale=0.5, size=q.shape))
    ni = len(system.inputs.names)
    u = np.array(system.inputs.values, dtype=float) + 0.1 if ni else None
    return q, w, u


def _close(got: np.ndarray, want: np.ndarray, what: str) -> None:
    assert got.shape == want.shape, what
    if want.size:
        assert np.abs(want).max() > 0, what
        err = np.abs(got - want).max() / np.abs(want).max()
        assert err <= CLOSE, f"{what}: relative difference {err:.3g}"


_MODELS: dict[str, tuple[Model, Model]] = {}


def _models(key: str, request: pytest.FixtureRequest) -> tuple[Model, Model]:
    """(C, NumPy) Models of the system, built once per run (the C's Jacobians module is the
    fixtures' when shared)."""
    if key not in _MODELS:
        s = _system(key, request)
        c = request.getfixturevalue(key) if key in FIXTURES else Model(s)
        _MODELS[key] = (c, Model(s.with_jacobians(), "numpy"))
    return _MODELS[key]


@pytest.mark.parametrize("key", KEYS)
def test_numpy_step_jacobians_match_c(key: str, request: pytest.FixtureRequest) -> None:
    """A, B, P (embedding coordinates) and the state after the step, every method, NumPy
    against C, at a state, time and inputs where no derivative is degenerate."""
    c, py = _models(key, request)
    q, w, u = _start(c.system)
    for name in _methods(c.system):
        want = c.linearize(q, w, H, name, t=T0, u=u, basis="embedding", options=EXACT)
        got = py.linearize(q, w, H, name, t=T0, u=u, basis="embedding", options=EXACT)
        assert np.allclose(got.q, want.q, 0, 1e-14) and np.allclose(got.omega, want.omega, 0, 1e-13)
        for field in ("A", "B", "P"):
            _close(getattr(got, field), getattr(want, field), f"{key} {name} {field}")


@pytest.mark.parametrize("key", KEYS)
def test_numpy_field_jacobian_matches_c(key: str, request: pytest.FixtureRequest) -> None:
    """J, Ju, Jp (embedding and tangent) and the field, NumPy against C."""
    c, py = _models(key, request)
    q, w, u = _start(c.system)
    for basis in ("embedding", "tangent"):
        want = c.jacobian_field(q, w, t=T0, u=u, basis=basis)
        got = py.jacobian_field(q, w, t=T0, u=u, basis=basis)
        assert np.allclose(got.wdot, want.wdot, 1e-13, 1e-13)
        for field in ("J", "Ju", "Jp"):
            _close(getattr(got, field), getattr(want, field), f"{key} {basis} {field}")


def _step(model: Model, x: np.ndarray, name: str, u: np.ndarray | None, **kw: object) -> np.ndarray:
    n = model.system.n
    q, w = model.step(
        x[: 3 * n].reshape(n, 3), x[3 * n :].reshape(n, 3), H, name, EXACT, t=T0, u=u, **kw
    )  # type: ignore[arg-type]
    return np.concatenate([np.ravel(q), np.ravel(w)])


#: (system, method): a coupled M with forces that depend on w, an input and a time-dependent
#: V (whose Hessian is zero); a diagonal M whose V couples the bodies, inputs in V and the
#: forces; springs between bodies (pair terms sharing bodies); a banded M with chain and body
#: terms
DIFFERENCE_CASES = [
    ("driven", "vi"),
    ("driven", "vi4"),
    ("driven", "rk4"),
    ("ring", "vi"),
    ("ring", "rk2"),
    ("four", "vi"),
    ("banded", "vi"),
]


@pytest.mark.parametrize(("key", "name"), DIFFERENCE_CASES)
def test_numpy_jacobians_match_central_differences_of_the_numpy_step(
    key: str, name: str, request: pytest.FixtureRequest
) -> None:
    """Independent of the C: the NumPy backend's A (tangent and embedding), B and P against
    central differences of the NumPy module's own step, relative agreement 1e-6."""
    _, py = _models(key, request)
    s = py.system
    n = s.n
    q0, w0, u = _start(s)
    x0 = np.concatenate([np.ravel(q0), np.ravel(w0)])
    tan = py.linearize(q0, w0, H, name, t=T0, u=u, options=EXACT)
    emb = py.linearize(q0, w0, H, name, t=T0, u=u, basis="embedding", options=EXACT)
    after = np.concatenate([np.ravel(emb.q), np.ravel(emb.omega)])
    assert np.allclose(after, _step(py, x0, name, u), 0, 1e-14)
    scale = np.abs(emb.A).max()

    def f(x: np.ndarray) -> np.ndarray:
        return _step(py, x, name, u)

    along = _central(f, x0, tan.basis_in)
    assert np.abs(tan.A - tan.basis_out.T @ along).max() <= 1e-6 * scale
    if method(name).family is Family.VI:
        assert np.abs(tan.basis_out @ tan.A - along).max() <= 1e-6 * scale
    assert np.abs(emb.A - _central(f, x0, np.eye(6 * n))).max() <= 1e-6 * scale
    if u is not None:
        fd = _central(lambda v: _step(py, x0, name, v), u, np.eye(len(u)))
        assert np.abs(emb.B - fd).max() <= 1e-6 * np.abs(fd).max()
    base = dict(zip(s.parameter_names, s.parameter_values))
    fp = np.zeros_like(emb.P)
    for k, pname in enumerate(s.parameter_names):
        eps = 1e-6 * max(abs(base[pname]), 1.0)
        ends = [
            _step(py, x0, name, u, params={**base, pname: base[pname] + e}) for e in (eps, -eps)
        ]
        fp[:, k] = (ends[0] - ends[1]) / (2 * eps)
    assert np.abs(emb.P - fp).max() <= 1e-6 * np.abs(fp).max()


def test_numpy_lyapunov_matches_c(request: pytest.FixtureRequest) -> None:
    """The Lyapunov spectrum through the NumPy step Jacobians is the C's (the same products of
    the same matrices, to round-off) over a short run."""
    c, py = _models("double", request)
    s = c.system
    want = c.lyapunov(s.q0, s.omega0, h=H, T=0.5, method="vi", blocks=5)
    got = py.lyapunov(s.q0, s.omega0, h=H, T=0.5, method="vi", blocks=5)
    assert np.allclose(got.exponents, want.exponents, 0, 1e-9)


def test_numpy_step_jacobian_refuses_in_one_line(request: pytest.FixtureRequest) -> None:
    """A method without a step Jacobian and h <= 0 are refused by status, as the C's are."""
    _, py = _models("double", request)
    s = py.system
    with pytest.raises(ValueError, match="method 'rk45' has no step Jacobian"):
        py.linearize(s.q0, s.omega0, H, "rk45")
    module = py._backend.module
    p = py.params()
    assert (
        module.step_jacobian(p, method("rk45").code, 0.0, H, s.q0, s.omega0)[0]
        == module.ERR_ARGUMENT
    )
    assert (
        module.step_jacobian(p, method("vi").code, 0.0, -H, s.q0, s.omega0)[0]
        == module.ERR_ARGUMENT
    )


def test_docs_backends_block() -> None:
    """The block of docs/user_guide/linearization.rst's "Backends", run as it stands: its
    NumPy linearization is its C one to 1e-10 (what the page says of it)."""
    text = section(page("user_guide/linearization.rst"), "Backends")
    (code,) = code_blocks(text, "python")
    ns: dict[str, object] = {}
    exec(compile(code, "linearization.rst", "exec"), ns)  # noqa: S102 (the page's own example)
    c, py = ns["in_c"], ns["in_numpy"]
    for field in ("A", "B", "P"):
        _close(getattr(py, field), getattr(c, field), f"docs {field}")
