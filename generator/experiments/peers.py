"""Outside peers for `s2gen bench`: scipy's `solve_ivp` and PyDy, measured in the same run.

Input: a `System` (scipy: any; PyDy: the double spherical pendulum), tolerances and a horizon.
Output: `PeerRun`s holding the final state as (q, omega) on (S^2)^n, the largest energy
deviation on an output grid, the right-hand-side evaluations and the best-of-k wall time, so the
benchmark compares them exactly as it compares our own integrators.

- scipy: `solve_ivp` (RK45, DOP853) on the emitted NumPy module's ``rhs(p, q, w)`` wrapped to
  flat vectors, as a Python user would write it (`numpy_field`); `c_field` wraps the emitted C
  right-hand side the same way (used for long DOP853 runs, where Python overhead would dominate).
- PyDy: the double spherical pendulum in angles, built with `sympy.physics.mechanics`
  (Kane's method) and `pydy.codegen.ode_function_generators.generate_ode_function`; generator
  "cython" when Cython is importable and its build works, else "lambdify". Each body's unit
  vector is written in the chart q = Ry(b) Rx(a) e3 = (cos a sin b, -sin a, cos a cos b), whose
  poles are +-e2: the pendulum's initial state is regular there (body 2 starts at e3, the pole
  of the usual polar chart). Angles map back to q, and omega = q x qdot, so errors are measured
  on (S^2)^n like ours. Code generation and compilation are timed.

Example:
    >>> import s2gen
    >>> s = s2gen.load("double_pendulum")
    >>> r = scipy_run(s, "DOP853", 1e-8, T=1.0)
    >>> r.status, r.q.shape
    ('ok', (2, 3))
"""

from __future__ import annotations

import importlib.util
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from s2gen import System
from s2gen.inspect import get_backend

__all__ = [
    "PeerRun",
    "PydyModel",
    "c_field",
    "numpy_field",
    "pydy_available",
    "pydy_model",
    "pydy_run",
    "scipy_run",
]

Field = Callable[[float, np.ndarray], np.ndarray]


@dataclass
class PeerRun:
    """One peer run: final state on (S^2)^n, max |E - E0| on the output grid, cost.

    `evals` counts right-hand-side evaluations (each is one gradient of V); `steps` is 0
    where the peer does not report it.
    """

    name: str
    rtol: float
    atol: float
    T: float
    q: np.ndarray
    omega: np.ndarray
    max_dE: float
    evals: int
    steps: int
    wall: float
    status: str = "ok"
    extra: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------------------------- fields
def numpy_field(system: System, params: np.ndarray | None = None) -> Field:
    """f(t, y) on flat y = (q, omega) from the emitted NumPy module's ``rhs(p, q, w)``.

    Example:
        >>> import s2gen
        >>> s = s2gen.load("double_pendulum")
        >>> f = numpy_field(s)
        >>> f(0.0, np.concatenate([s.q0.ravel(), s.omega0.ravel()])).shape
        (12,)
    """
    module = get_backend(system, "numpy").module
    p = np.array(system.parameter_values if params is None else params, dtype=float)
    n3 = 3 * system.n
    shape = (system.n, 3)

    def f(t: float, y: np.ndarray) -> np.ndarray:
        dq, dw = module.rhs(p, y[:n3].reshape(shape), y[n3:].reshape(shape))
        return np.concatenate((np.ravel(dq), np.ravel(dw)))

    return f


def c_field(system: System, params: np.ndarray | None = None) -> Field:
    """f(t, y) on flat y = (q, omega) from the emitted C right-hand side (through ctypes).

    Example:
        >>> import s2gen
        >>> s = s2gen.load("double_pendulum")
        >>> y = np.concatenate([s.q0.ravel(), s.omega0.ravel()])
        >>> bool(np.allclose(c_field(s)(0.0, y), numpy_field(s)(0.0, y)))
        True
    """
    be = get_backend(system, "c")
    p = np.array(system.parameter_values if params is None else params, dtype=float)
    n3 = 3 * system.n
    shape = (system.n, 3)

    def f(t: float, y: np.ndarray) -> np.ndarray:
        dq, dw = be.rhs(y[:n3].reshape(shape), y[n3:].reshape(shape), p)
        return np.concatenate((dq.ravel(), dw.ravel()))

    return f


def _energy_fn(system: System) -> Callable[[np.ndarray, np.ndarray], float]:
    be = get_backend(system, "c")
    p = np.array(system.parameter_values, dtype=float)
    return lambda q, w: be.energy(q, w, p)


def _best_of(k: int, fn: Callable[[], Any]) -> tuple[Any, float]:
    best, out = float("inf"), None
    for _ in range(max(1, k)):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return out, best


# -------------------------------------------------------------------------------------- scipy
def scipy_run(
    system: System,
    method: str,
    rtol: float,
    T: float,
    atol: float | None = None,
    samples: int = 200,
    repeats: int = 1,
    rhs: str = "numpy",
) -> PeerRun:
    """`scipy.integrate.solve_ivp` with `method` ("RK45", "DOP853") from the system's state.

    The energy is evaluated afterwards (untimed) on `samples` + 1 equally spaced outputs
    (dense output) with the emitted C energy. `rhs` is "numpy" (emitted NumPy module) or "c".

    Example:
        >>> import s2gen
        >>> r = scipy_run(s2gen.load("double_pendulum"), "RK45", 1e-6, T=0.5)
        >>> r.status, r.evals > 0
        ('ok', True)
    """
    from scipy.integrate import solve_ivp

    atol = rtol if atol is None else atol
    f = numpy_field(system) if rhs == "numpy" else c_field(system)
    q0, w0 = _initial(system)
    y0 = np.concatenate([q0.ravel(), w0.ravel()])
    t_eval = np.linspace(0.0, T, samples + 1)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        sol, wall = _best_of(
            repeats,
            lambda: solve_ivp(f, (0.0, T), y0, method=method, rtol=rtol, atol=atol, t_eval=t_eval),
        )
    name = f"scipy-{method}"
    if not sol.success or not np.all(np.isfinite(sol.y)):
        return _failed(system, name, rtol, atol, T, wall, str(sol.message))
    q, w = _split(sol.y.T, system.n)
    energy = _energy_fn(system)
    dE = max(abs(energy(q[k], w[k]) - energy(q[0], w[0])) for k in range(len(q)))
    return PeerRun(name, rtol, atol, T, q[-1], w[-1], float(dE), int(sol.nfev), 0, wall)


def _initial(system: System) -> tuple[np.ndarray, np.ndarray]:
    if system.q0 is None or system.omega0 is None:
        raise ValueError(f"{system.origin}: no initial state ([initial] q and omega)")
    return system.q0, system.omega0


def _split(y: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    k = len(y)
    return y[:, : 3 * n].reshape(k, n, 3), y[:, 3 * n :].reshape(k, n, 3)


def _failed(
    system: System, name: str, rtol: float, atol: float, T: float, wall: float, why: str
) -> PeerRun:
    nan = np.full((system.n, 3), np.nan)
    return PeerRun(name, rtol, atol, T, nan, nan, float("nan"), 0, 0, wall, f"failed: {why}")


# --------------------------------------------------------------------------------------- PyDy
def pydy_available() -> str | None:
    """None when PyDy can be imported, else the reason it cannot.

    Example:
        >>> pydy_available() is None or isinstance(pydy_available(), str)
        True
    """
    try:
        import pydy.codegen.ode_function_generators  # noqa: F401
    except Exception as exc:  # noqa: BLE001 - any import failure means "not available"
        return f"{type(exc).__name__}: {exc}"
    return None


@dataclass
class PydyModel:
    """A PyDy right-hand side of the double spherical pendulum in angles, with build times."""

    rhs: Callable[[np.ndarray, float, np.ndarray], np.ndarray]
    generator: str
    derive_seconds: float
    generate_seconds: float
    params: np.ndarray
    note: str = ""

    @property
    def build_seconds(self) -> float:
        """Derivation (Kane's method) plus code generation and compilation."""
        return self.derive_seconds + self.generate_seconds


def _chart(a: Any, b: Any, lib: Any) -> tuple[Any, Any, Any]:
    """q = Ry(b) Rx(a) e3 in components (lib: sympy or numpy)."""
    return (lib.cos(a) * lib.sin(b), -lib.sin(a), lib.cos(a) * lib.cos(b))


def _derive_pendulum() -> tuple[Any, list[Any], list[Any], list[Any]]:
    """Kane's equations of two point masses on massless rods with spherical joints."""
    import sympy as sp
    import sympy.physics.mechanics as me

    a1, b1, a2, b2 = me.dynamicsymbols("a1 b1 a2 b2")
    us = list(me.dynamicsymbols("u1:5"))
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g", positive=True)
    frame = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(frame, 0)

    def unit(a: Any, b: Any) -> Any:
        x, y, z = _chart(a, b, sp)
        return x * frame.x + y * frame.y + z * frame.z

    coords = [a1, b1, a2, b2]
    rates = {c.diff(): u for c, u in zip(coords, us)}
    p1 = origin.locatenew("P1", l1 * unit(a1, b1))
    p2 = p1.locatenew("P2", l2 * unit(a2, b2))
    p1.set_vel(frame, p1.pos_from(origin).dt(frame).subs(rates))
    p2.set_vel(frame, p2.pos_from(origin).dt(frame).subs(rates))
    kane = me.KanesMethod(
        frame, q_ind=coords, u_ind=us, kd_eqs=[c.diff() - u for c, u in zip(coords, us)]
    )
    particles = [me.Particle("p1", p1, m1), me.Particle("p2", p2, m2)]
    # V = -(m1+m2) g l1 e3.q1 - m2 g l2 e3.q2: gravity m_k g along +e3 on each mass
    kane.kanes_equations(particles, [(p1, m1 * g * frame.z), (p2, m2 * g * frame.z)])
    return kane, coords, us, [m1, m2, l1, l2, g]


def pydy_model(system: System, generator: str = "auto") -> PydyModel:
    """Derive and generate PyDy's double-pendulum right-hand side f(x, t, p), timed.

    `generator` is "cython", "lambdify" or "auto" (cython if its build works, else lambdify;
    the reason for a fallback is kept in `.note`). Parameters follow the system's order
    (m1, m2, l1, l2, g).

    Example:
        >>> import s2gen
        >>> m = pydy_model(s2gen.load("double_pendulum"), "lambdify")
        >>> m.generator, m.rhs(np.zeros(8), 0.0, m.params).shape
        ('lambdify', (8,))
    """
    from pydy.codegen.ode_function_generators import generate_ode_function

    if tuple(system.parameter_names) != ("m1", "m2", "l1", "l2", "g") or system.n != 2:
        raise ValueError(f"the PyDy peer models the double pendulum only, not {system.name}")
    start = time.perf_counter()
    kane, coords, speeds, consts = _derive_pendulum()
    derived = time.perf_counter()
    note = ""
    choice = generator
    if generator == "auto":
        choice = "cython" if importlib.util.find_spec("Cython") else "lambdify"
        if choice == "lambdify":
            note = "Cython is not installed: PyDy's lambdify generator used"
    args = (kane.forcing_full, coords, speeds, consts)
    try:
        rhs = _generate(generate_ode_function, args, kane.mass_matrix_full, choice)
    except Exception as exc:
        if generator != "auto" or choice != "cython":
            raise
        note = f"PyDy's cython generator failed ({type(exc).__name__}); lambdify used"
        choice = "lambdify"
        derived = time.perf_counter()
        rhs = _generate(generate_ode_function, args, kane.mass_matrix_full, choice)
    done = time.perf_counter()
    params = np.array(system.parameter_values, dtype=float)
    return PydyModel(rhs, choice, derived - start, done - derived, params, note)


def _generate(gen: Any, args: tuple[Any, ...], mass: Any, choice: str) -> Any:
    kwargs: dict[str, Any] = {"mass_matrix": mass, "generator": choice}
    if choice == "cython":
        kwargs["tmp_dir"] = tempfile.mkdtemp(prefix="s2gen-pydy-")
    return gen(*args, constants_arg_type="array", **kwargs)


def angles_from_state(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """PyDy state (a1, b1, a2, b2, rates) from unit vectors q (n, 3) and omega (n, 3).

    Example:
        >>> q = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
        >>> (angles_from_state(q, np.zeros((2, 3)))[:4] + 0.0).round(4).tolist()
        [0.0, 0.0, 0.0, 1.5708]
    """
    angles, rates = [], []
    for qi, wi in zip(q, w):
        a = float(np.arctan2(-qi[1], np.hypot(qi[0], qi[2])))
        b = float(np.arctan2(qi[0], qi[2]))
        jac = _chart_jacobian(a, b)
        r, *_ = np.linalg.lstsq(jac, np.cross(wi, qi), rcond=None)
        angles += [a, b]
        rates += list(r)
    return np.array(angles + rates)


def _chart_jacobian(a: float, b: float) -> np.ndarray:
    sa, ca, sb, cb = np.sin(a), np.cos(a), np.sin(b), np.cos(b)
    return np.array([[-sa * sb, ca * cb], [-ca, 0.0], [-sa * cb, -ca * sb]])


def state_from_angles(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(q, omega), each (2, 3), from a PyDy state: q from the chart, omega = q x qdot.

    Example:
        >>> q0 = np.array([[0.6, 0.0, 0.8], [0.0, 0.0, 1.0]])
        >>> w0 = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
        >>> q, w = state_from_angles(angles_from_state(q0, w0))
        >>> bool(np.allclose(q, q0) and np.allclose(w, w0))
        True
    """
    q, w = np.zeros((2, 3)), np.zeros((2, 3))
    for i in range(2):
        a, b = x[2 * i], x[2 * i + 1]
        q[i] = _chart(a, b, np)
        qdot = _chart_jacobian(a, b) @ x[4 + 2 * i : 6 + 2 * i]
        w[i] = np.cross(q[i], qdot)
    return q, w


def pydy_run(
    system: System,
    model: PydyModel,
    integrator: str,
    rtol: float,
    T: float,
    atol: float | None = None,
    samples: int = 200,
    repeats: int = 1,
) -> PeerRun:
    """Integrate PyDy's right-hand side with "lsoda" (odeint, PyDy's default) or "DOP853".

    Example:
        >>> import s2gen
        >>> s = s2gen.load("double_pendulum")
        >>> r = pydy_run(s, pydy_model(s, "lambdify"), "DOP853", 1e-8, T=0.5)
        >>> r.status, r.max_dE < 1e-4
        ('ok', True)
    """
    atol = rtol if atol is None else atol
    x0 = angles_from_state(*_initial(system))
    t_eval = np.linspace(0.0, T, samples + 1)
    name = f"pydy-{model.generator}-{integrator}"
    if integrator == "lsoda":
        (xs, nfev, ok, why), wall = _best_of(
            repeats, lambda: _odeint(model, x0, t_eval, rtol, atol)
        )
    else:
        (xs, nfev, ok, why), wall = _best_of(
            repeats, lambda: _solve_ivp(model, x0, t_eval, integrator, rtol, atol)
        )
    if not ok or not np.all(np.isfinite(xs)):
        return _failed(system, name, rtol, atol, T, wall, why)
    states = [state_from_angles(x) for x in xs]
    energy = _energy_fn(system)
    e0 = energy(*states[0])
    dE = max(abs(energy(q, w) - e0) for q, w in states)
    pole = float(np.pi / 2 - np.max(np.abs(np.asarray(xs)[:, [0, 2]])))
    q, w = states[-1]
    extra = {"pole_distance": pole}
    return PeerRun(name, rtol, atol, T, q, w, float(dE), nfev, 0, wall, "ok", extra)


def _odeint(
    model: PydyModel, x0: np.ndarray, t_eval: np.ndarray, rtol: float, atol: float
) -> tuple[np.ndarray, int, bool, str]:
    from scipy.integrate import odeint

    xs, info = odeint(
        model.rhs,
        x0,
        t_eval,
        args=(model.params,),
        rtol=rtol,
        atol=atol,
        full_output=True,
        mxstep=10**7,
    )
    return xs, int(info["nfe"][-1]), info["message"] == "Integration successful.", info["message"]


def _solve_ivp(
    model: PydyModel, x0: np.ndarray, t_eval: np.ndarray, method: str, rtol: float, atol: float
) -> tuple[np.ndarray, int, bool, str]:
    from scipy.integrate import solve_ivp

    sol = solve_ivp(
        lambda t, x: model.rhs(x, t, model.params),
        (0.0, float(t_eval[-1])),
        x0,
        method=method,
        rtol=rtol,
        atol=atol,
        t_eval=t_eval,
    )
    return sol.y.T, int(sol.nfev), bool(sol.success), str(sol.message)
