"""The continuous field's Jacobian, in the tangent basis or the embedding coordinates.

Input: a C or NumPy backend whose module has field_jacobian() (built from
`System.with_jacobians`), or the reference backend (the complex-step derivative of its own
field, `s2gen.reference.field_jacobian`: an independent check), a state, time and inputs.
Output: a `FieldJacobian`.

The field is f(x) = (qdot, wdot) with qdot_i = w_i x q_i and A(q) wdot = b(q, w, t, u), x =
(q, w) in the embedding order of `s2gen.runtime.linearize`. The emitted C returns J = df/dx
(6n x 6n) and Ju = df/du exactly (SymPy's derivatives, the ones step_jacobian() propagates
through a Runge-Kutta stage). In the tangent basis E(x) of `s2gen.runtime.linearize.
tangent_basis` a solution's variation dx = E(x(t)) xi obeys E xi' + (dE/dt) xi = J E xi, so

    xi' = J_t xi + B_t du,   J_t = E^T J E - E^T (dE/dt),   B_t = E^T Ju,

dE/dt being the derivative of the basis along the field (`basis_rate`, exact: the frame and
its whitening differentiated by hand). J_t is the 4n x 4n generator of `linearize`'s tangent
A: one step of a Runge-Kutta method of size h has A = I + h J_t + O(h^2) in the tangent basis
as A = I + h J does in the embedding. At an equilibrium (f = 0) the rate term vanishes and J_t
is the projection E^T J E.

Example:
    >>> import numpy as np
    >>> q = np.array([[0.0, 0.6, -0.8]]); w = np.array([[0.5, 0.8, 0.6]])
    >>> dq = np.cross(w, q)
    >>> basis_rate(q, w, dq, np.zeros((1, 3))).shape
    (6, 4)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.methods import Status
from s2gen.runtime.c import CBackend, contiguous, pointer
from s2gen.runtime.linearize import BASES, frame, jacobian_features, tangent_basis

__all__ = ["FieldJacobian", "basis_rate", "jacobian_field"]


@dataclass(frozen=True)
class FieldJacobian:
    """The field's derivatives at one state in `basis`: `J` = d(qdot, wdot)/d(q, w) ("tangent":
    4n x 4n, the generator of the variations in the tangent coordinates, see the module
    docstring; "embedding": 6n x 6n), `Ju` = d(qdot, wdot)/du and `Jp` = d(qdot, wdot)/dp (the
    parameters in the order of `Model.params`; 4n or 6n rows), the field
    itself (`qdot`, `wdot`, shape (n, 3)) and the tangent basis at the state (`basis_at`,
    6n x 4n)."""

    J: np.ndarray
    Ju: np.ndarray
    Jp: np.ndarray
    qdot: np.ndarray
    wdot: np.ndarray
    basis: str
    basis_at: np.ndarray


def _frame_rate(q: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """The derivative of `frame` at unit rows q along dq: shape (n, 3, 2)."""
    ex = np.array([1.0, 0.0, 0.0])
    den = 1.0 + q[:, :1]
    s = (q + ex) / den
    ds = dq / den - (q + ex) * dq[:, :1] / den**2
    de1 = -dq[:, 1:2] * s - q[:, 1:2] * ds
    de2 = -dq[:, 2:3] * s - q[:, 2:3] * ds
    return np.stack([de1, de2], axis=2)


def basis_rate(q: np.ndarray, w: np.ndarray, dq: np.ndarray, dw: np.ndarray) -> np.ndarray:
    """The derivative of `tangent_basis(q, w)` along (dq, dw) (all of shape (n, 3), the rows
    of q of unit length, dq_i perpendicular to q_i): shape (6n, 4n), rows and columns as the
    basis's.

    Example:
        >>> q = np.array([[0.0, 0.0, -1.0]]); w = np.array([[0.2, 0.1, 0.0]])
        >>> bool(np.allclose(basis_rate(q, w, np.zeros((1, 3)), np.zeros((1, 3))), 0))
        True
    """
    q, w = np.asarray(q, dtype=float), np.asarray(w, dtype=float)
    dq, dw = np.asarray(dq, dtype=float), np.asarray(dw, dtype=float)
    n = len(q)
    fr, dfr = frame(q), _frame_rate(q, dq)
    out = np.zeros((6 * n, 4 * n))
    for i in range(n):
        E, dE = fr[i], dfr[i]
        c = E.T @ w[i]
        dc = dE.T @ w[i] + E.T @ dw[i]
        r = np.sqrt(1.0 + c @ c)
        dr = (c @ dc) / r
        k = r * (r + 1.0)
        dk = dr * (2.0 * r + 1.0)
        cc = np.outer(c, c)
        whiten = np.eye(2) - cc / k
        dwhiten = -(np.outer(dc, c) + np.outer(c, dc)) / k + cc * dk / k**2
        side = np.vstack([E, -np.outer(q[i], c)])
        dside = np.vstack([dE, -np.outer(dq[i], c) - np.outer(q[i], dc)])
        top = dside @ whiten + side @ dwhiten
        out[3 * i : 3 * i + 3, 4 * i : 4 * i + 2] = top[:3]
        out[3 * n + 3 * i : 3 * n + 3 * i + 3, 4 * i : 4 * i + 2] = top[3:]
        out[3 * n + 3 * i : 3 * n + 3 * i + 3, 4 * i + 2 : 4 * i + 4] = dE
    return out


def jacobian_field(
    backend: Any,
    q: np.ndarray,
    w: np.ndarray,
    params: np.ndarray,
    t: float = 0.0,
    u: np.ndarray | None = None,
    basis: str = "tangent",
) -> FieldJacobian:
    """The `FieldJacobian` at (q, w) (shape (n, 3)) at time t with the inputs u (None: the
    spec's defaults) on a `CBackend` or `NumpyBackend` whose module has field_jacobian(), or
    the reference backend (the complex-step derivative of its own field,
    `s2gen.reference.field_jacobian`).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> be = CBackend(s.with_jacobians())
        >>> fj = jacobian_field(be, s.q0, s.omega0, be.default_params())
        >>> fj.J.shape, fj.Ju.shape, fj.basis_at.shape
        ((8, 8), (8, 0), (12, 8))
    """
    system = backend.system
    if basis not in BASES:
        raise ValueError(f"basis {basis!r}: choose one of {', '.join(BASES)}")
    reference = backend.name == "reference"
    if not reference and not jacobian_features(backend)[0]:
        raise ValueError(f"{system.name}: field_jacobian needs the module with Jacobians")
    n, ni = system.n, len(system.inputs.names)
    q0 = contiguous(np.asarray(q, dtype=float).reshape(n, 3))
    w0 = contiguous(np.asarray(w, dtype=float).reshape(n, 3))
    uu = None if u is None else contiguous(np.asarray(u, dtype=float).reshape(ni))
    if reference:
        qd, wd, J, Ju, Jp = backend.field_jacobian(np.asarray(params, dtype=float), t, q0, w0, uu)
        status = 0
    elif isinstance(backend, CBackend):
        qd, wd = np.empty((n, 3)), np.empty((n, 3))
        npar = len(system.parameter_names)
        J, Ju, Jp = np.empty((6 * n, 6 * n)), np.empty((6 * n, ni)), np.empty((6 * n, npar))
        work = np.zeros(backend.library.jacobian_work)
        status = backend.library.fn["field_jacobian"](
            contiguous(params),
            float(t),
            pointer(uu),
            q0,
            w0,
            pointer(qd),
            pointer(wd),
            J,
            pointer(Ju) if ni else None,
            pointer(Jp) if npar else None,
            work,
        )
    else:
        status, qd, wd, J, Ju, Jp = backend.module.field_jacobian(
            np.asarray(params, dtype=float), float(t), q0, w0, uu
        )
    if status != 0:
        st = Status(status)
        raise ValueError(f"{system.name}: field_jacobian: {st.c_name}: {st.message}")
    E = tangent_basis(q0, w0)
    if basis == "tangent":
        unit = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
        rate = basis_rate(unit, w0, qd, wd)
        J, Ju, Jp = E.T @ J @ E - E.T @ rate, E.T @ Ju, E.T @ Jp
    return FieldJacobian(J, Ju, Jp, qd, wd, basis, E)
