"""Linearize one step: the exact Jacobians of the emitted step, in the tangent basis or the
embedding coordinates.

Input: a C or NumPy backend whose module has step_jacobian() (built from
`System.with_jacobians`: systems of a few bodies), or the reference backend (its step's
complex-step derivative, `s2gen.reference.step_jacobian`: an independent check), a state, a step size, a fixed-step method,
time and inputs. Output: a `Linearization`. The two backends' step_jacobian() print the same
kernels and agree to round-off (`tests/test_numpy_jacobian.py`).

The tangent basis. The state (q, w) lives on T(S^2)^n = {|q_i| = 1, q_i . w_i = 0}, of
dimension 4n inside the 6n embedding coordinates x = (q, w) (the 3n components of q
body-major, then the 3n of w). At each body a frame of T_q S^2 is built from q by a fixed rule:
the rotation R(q) that takes e_x to q along the great circle between them carries e_y and e_z
to
    e_1(q) = e_y - q_y/(1 + q_x) (e_x + q),   e_2(q) = e_z - q_z/(1 + q_x) (e_x + q),
orthonormal, orthogonal to q, e_1 x e_2 = q, and smooth everywhere but at q = -e_x (the
hanging q = -e_z and upright q = e_z states are far from it). A tangent vector of
T(S^2)^n at (q, w) is (dq, dw) with dq_i = E_i alpha_i and q_i . dw_i = -w_i . dq_i (the
derivative of q_i . w_i = 0), so dw_i = E_i beta_i - (w_i . E_i alpha_i) q_i. The columns
(E_i alpha, -(w_i . E_i alpha) q_i) for alpha = e_1, e_2 have the Gram matrix I + c c^T,
c = E_i^T w_i; multiplied by its inverse square root I - c c^T / (r (r + 1)), r = sqrt(1 + |c|^2),
they are orthonormal, and with (0, E_i e_k) they make 4 orthonormal columns per body
(`tangent_basis`: body i's coordinates (alpha_i, beta_i) are columns 4i .. 4i + 3). With
basis_in at the state before the step and basis_out at the state after it (q+_i normalized to
build the frame), A_tangent = basis_out^T A basis_in and B_tangent = basis_out^T B, so that
basis_out @ A_tangent @ basis_in.T maps a small tangent displacement of x to the displacement
after the step. P (dx+/dp, one column per parameter) is B's kind: P_tangent = basis_out^T P.

Example:
    >>> import numpy as np
    >>> q = np.array([[0.0, 0.6, -0.8]]); w = np.array([[1.0, 0.8, 0.6]])
    >>> E = tangent_basis(q, w)
    >>> E.shape, bool(np.allclose(E.T @ E, np.eye(4)))
    ((6, 4), True)
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.equations.jacobian import jacobian_refusal
from s2gen.equations.rattle_jacobian import has_rattle_jacobian
from s2gen.methods import METHODS, Family, Status, driven_methods, fixed_methods, method
from s2gen.runtime.c import CBackend, contiguous, pointer
from s2gen.runtime.options import Options

__all__ = [
    "BASES",
    "Linearization",
    "frame",
    "jacobian_features",
    "linearize",
    "step_jacobian",
    "tangent_basis",
]

#: The coordinates `linearize` returns A and B in
BASES = ("tangent", "embedding")


@dataclass(frozen=True)
class Linearization:
    """One step's derivatives: `A` = dx+/dx, `B` = dx+/du and `P` = dx+/dp in `basis`
    ("tangent": 4n x 4n, 4n x inputs and 4n x parameters; "embedding": 6n rows; P's columns
    in the order of the parameters, `System.parameter_names`), the state after the step
    (`q`, `omega`, shape (n, 3)) and the tangent bases at the state before and after it
    (`basis_in`, `basis_out`: 6n x 4n, orthonormal columns, see the module docstring)."""

    A: np.ndarray
    B: np.ndarray
    P: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    basis: str
    basis_in: np.ndarray
    basis_out: np.ndarray


def frame(q: np.ndarray) -> np.ndarray:
    """The frames (e_1, e_2) of T_q S^2 for q of shape (n, 3) (unit rows): shape (n, 3, 2).

    Example:
        >>> frame(np.array([[0.0, 0.0, -1.0]]))[0].T.tolist()
        [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
    """
    q = np.asarray(q, dtype=float)
    if np.any(q[:, 0] <= -1.0 + 1e-12):
        raise ValueError("the tangent frame is not defined at q = -e_x")
    s = (q + np.array([1.0, 0.0, 0.0])) / (1.0 + q[:, :1])
    e1 = np.array([0.0, 1.0, 0.0]) - q[:, 1:2] * s
    e2 = np.array([0.0, 0.0, 1.0]) - q[:, 2:3] * s
    return np.stack([e1, e2], axis=2)


def tangent_basis(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The orthonormal basis of the tangent space of T(S^2)^n at (q, w), q and w of shape
    (n, 3) (each q_i normalized first): shape (6n, 4n), rows in the embedding order.

    Example:
        >>> E = tangent_basis(np.array([[0.0, 0.0, 1.0]]), np.array([[0.3, 0.0, 0.0]]))
        >>> bool(np.allclose(E[:3].T @ [0.0, 0.0, 1.0], 0))
        True
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w = np.asarray(w, dtype=float)
    n = len(q)
    fr = frame(q)
    out = np.zeros((6 * n, 4 * n))
    for i in range(n):
        E = fr[i]
        c = E.T @ w[i]
        r = np.sqrt(1.0 + c @ c)
        whiten = np.eye(2) - np.outer(c, c) / (r * (r + 1.0))
        top = np.vstack([E, -np.outer(q[i], c)]) @ whiten
        out[3 * i : 3 * i + 3, 4 * i : 4 * i + 2] = top[:3]
        out[3 * n + 3 * i : 3 * n + 3 * i + 3, 4 * i : 4 * i + 2] = top[3:]
        out[3 * n + 3 * i : 3 * n + 3 * i + 3, 4 * i + 2 : 4 * i + 4] = E
    return out


def jacobian_features(backend: Any) -> tuple[bool, bool]:
    """(whether the backend's module has step_jacobian(), whether it differentiates the VI
    family too) for a C or NumPy backend; TypeError for another backend.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.runtime.numpy_module import NumpyBackend
        >>> jacobian_features(NumpyBackend(builtin("double_pendulum")))
        (False, False)
    """
    from s2gen.runtime.numpy_module import NumpyBackend

    if isinstance(backend, CBackend):
        return backend.library.jacobian, backend.library.jacobian_vi
    if isinstance(backend, NumpyBackend):
        return backend.jacobian, backend.jacobian_vi
    raise TypeError(
        f"{backend.system.name}: the emitted Jacobians run on the C or NumPy backend, not "
        f"{backend.name!r} (whose linearize is its own step's complex-step derivative)"
    )


def _refuse(backend: Any, method_name: str, basis: str) -> None:
    """A one-line ValueError for what `linearize` does not do."""
    system = backend.system
    if basis not in BASES:
        raise ValueError(f"basis {basis!r}: choose one of {', '.join(BASES)}")
    if backend.name == "reference":
        return  # the reference's step_jacobian names the methods it takes
    jacobian, jacobian_vi = jacobian_features(backend)
    if not jacobian:
        why = jacobian_refusal(system) or "built without them (System.with_jacobians)"
        raise ValueError(f"{system.name}: {why}")
    names = [m.name for m in fixed_methods("sphere")]
    if jacobian_vi:
        names += [m.name for m in METHODS if m.family is Family.VI]
    if has_rattle_jacobian(system):
        names += [m.name for m in METHODS if m.family is Family.RATTLE]
    allowed = [m for m in names if not system.driven or m in driven_methods()]
    if method_name not in allowed:
        more = "" if jacobian_vi else " (built without the VI family's)"
        raise ValueError(
            f"{system.name}: method {method_name!r} has no step Jacobian{more}; choose one of "
            f"{', '.join(allowed)}"
        )


def step_jacobian(
    backend: Any,
    method_name: str,
    t: float,
    h: float,
    q: np.ndarray,
    w: np.ndarray,
    u: np.ndarray | None,
    params: np.ndarray,
    options: Options,
) -> tuple[np.ndarray, ...]:
    """One call of the module's step_jacobian() on a C or NumPy backend (or the reference
    backend's, a complex-step derivative): (qn, wn, A, B, P) in the embedding coordinates,
    q, w of shape (n, 3), u the inputs (None: the defaults); ValueError naming the status of a
    failed step.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.runtime.numpy_module import NumpyBackend
        >>> s = builtin("double_pendulum")
        >>> be = NumpyBackend(s.with_jacobians())
        >>> qn, wn, A, B, P = step_jacobian(be, "vi", 0.0, 0.01, s.q0, s.omega0, None,
        ...                                 be.default_params(), Options())
        >>> A.shape, B.shape, P.shape
        ((12, 12), (12, 0), (12, 5))
    """
    system = backend.system
    if backend.name == "reference":
        return tuple(backend.step_jacobian(method_name, t, h, q, w, u, params, options))
    n, ni, npar = system.n, len(system.inputs.names), len(system.parameter_names)
    q0 = contiguous(np.asarray(q, dtype=float).reshape(n, 3))
    w0 = contiguous(np.asarray(w, dtype=float).reshape(n, 3))
    uu = None if u is None else contiguous(np.asarray(u, dtype=float).reshape(ni))
    if isinstance(backend, CBackend):
        qn, wn = np.empty((n, 3)), np.empty((n, 3))
        A, B, P = np.empty((6 * n, 6 * n)), np.empty((6 * n, ni)), np.empty((6 * n, npar))
        work = np.zeros(backend.library.jacobian_work)
        opt = backend.library.options(options)
        status = backend.library.fn["step_jacobian"](
            contiguous(params),
            ctypes.byref(opt),
            method(method_name).code,
            ctypes.c_double(t),
            ctypes.c_double(h),
            pointer(uu),
            q0,
            w0,
            qn,
            wn,
            A,
            pointer(B) if ni else None,
            pointer(P) if npar else None,
            work,
        )
    else:
        status, qn, wn, A, B, P = backend.module.step_jacobian(
            np.asarray(params, dtype=float),
            method(method_name).code,
            float(t),
            float(h),
            q0,
            w0,
            uu,
            newton_tol=options.newton_tol,
            newton_maxiter=options.newton_maxiter,
        )
    if status != 0:
        st = Status(status)
        raise ValueError(f"{system.name}: step_jacobian: {st.c_name}: {st.message}")
    return qn, wn, A, B, P


def linearize(
    backend: Any,
    q: np.ndarray,
    w: np.ndarray,
    h: float,
    method_name: str,
    params: np.ndarray,
    t: float = 0.0,
    u: np.ndarray | None = None,
    basis: str = "tangent",
    options: Options | None = None,
) -> Linearization:
    """The `Linearization` of one step of `method_name` from (q, w) (shape (n, 3)) at time t
    with the inputs u (None: the spec's defaults) on a `CBackend`, a `NumpyBackend` or the
    reference backend, with the step's `options` (None: the defaults).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> be = CBackend(s.with_jacobians())
        >>> lin = linearize(be, s.q0, s.omega0, 0.01, "rk4", be.default_params())
        >>> lin.A.shape, lin.B.shape, lin.P.shape, lin.basis_in.shape
        ((8, 8), (8, 0), (8, 5), (12, 8))
    """
    _refuse(backend, method_name, basis)
    opts = Options() if options is None else options
    qn, wn, A, B, P = step_jacobian(backend, method_name, t, h, q, w, u, params, opts)
    q0 = np.asarray(q, dtype=float).reshape(-1, 3)
    w0 = np.asarray(w, dtype=float).reshape(-1, 3)
    E_in, E_out = tangent_basis(q0, w0), tangent_basis(qn, wn)
    if basis == "tangent":
        A, B, P = E_out.T @ A @ E_in, E_out.T @ B, E_out.T @ P
    return Linearization(A, B, P, qn, wn, basis, E_in, E_out)
