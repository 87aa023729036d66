"""Jacobian-vector products of one step through the emitted step_jvp(): O(n) per product.

Input: a C backend whose module has step_jvp() (built from `System.with_jacobians` for a
system `s2gen.equations.jvp.has_jvp` covers: a diagonal M or a banded or max-index M with
the structured solvers, closed, any n) or the reference backend (one complex step through its
own step per product: any system and fixed-step method it differentiates, an independent
check), a state (q, omega), a tangent direction
(dq, domega) in the embedding coordinates (shape (n, 3) each), a step size and a fixed-step
Runge-Kutta method. Output: a `StepTangent`: the state after the step and the directional
derivative (dq+, domega+) = A (dq, domega), A = dx+/dx the step's Jacobian in the embedding
coordinates (`Model.linearize` with basis="embedding" forms it whole, for a few bodies).

Example:
    >>> from s2gen.systems import builtin
    >>> s = builtin("rope", n=200)
    >>> be = CBackend(s.with_jacobians())
    >>> st = step_jvp(be, s.q0, s.omega0, 1e-4, s.q0, 0 * s.omega0, "rk4", be.default_params())
    >>> st.dq.shape, float(abs((st.q * st.q).sum(axis=1) - 1).max()) < 1e-8
    ((200, 3), True)
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.equations.jvp import jvp_refusal
from s2gen.methods import METHODS, Family, Status, fixed_methods, method
from s2gen.runtime.c import CBackend, contiguous
from s2gen.runtime.options import Options

__all__ = ["StepTangent", "jvp_backend", "jvp_methods", "step_jvp"]


@dataclass(frozen=True)
class StepTangent:
    """One step and its tangent: the state after the step (`q`, `omega`, shape (n, 3)) and
    the directional derivative of the step along the given tangent (`dq`, `domega`, shape
    (n, 3)), in the embedding coordinates.

    Example:
        >>> z = np.zeros((1, 3))
        >>> StepTangent(z, z, z, z).dq.shape
        (1, 3)
    """

    q: np.ndarray
    omega: np.ndarray
    dq: np.ndarray
    domega: np.ndarray


def jvp_methods(vi: bool = False) -> tuple[str, ...]:
    """The methods step_jvp() takes: the fixed-step Runge-Kutta methods and, with `vi` (a
    module whose JVP_VI is 1), the VI family.

    Example:
        >>> jvp_methods(vi=True)
        ('rk2', 'rk2-proj', 'rk4', 'rk3', 'vi', 'vi4', 'vi6', 'vi8')
    """
    family = tuple(m.name for m in METHODS if m.family is Family.VI) if vi else ()
    return (*(m.name for m in fixed_methods("sphere")), *family)


def jvp_backend(model: Any) -> Any:
    """The backend with step_jvp() of a `Model`: its own when it has it, else (C) the module
    built once from `System.with_jacobians` when first asked for (the one `Model.linearize`
    builds, kept in the same place).

    Example:
        >>> from s2gen.runtime.model import Model
        >>> from s2gen.systems import builtin
        >>> jvp_backend(Model(builtin("four_pendula"))).library.jvp
        True
    """
    backend = model._backend
    if isinstance(backend, CBackend) and not backend.library.jvp:
        why = jvp_refusal(model.system)
        if why is not None:
            raise ValueError(why)
        if model._jacobians is None:
            model._jacobians = CBackend(model.system.with_jacobians())
        backend = model._jacobians
    return backend


def _refuse(backend: Any, method_name: str) -> None:
    system = backend.system
    if not isinstance(backend, CBackend):
        raise TypeError(
            f"{system.name}: step_jvp runs on the C and reference backends, not {backend.name!r}"
        )
    if not backend.library.jvp:
        why = jvp_refusal(system) or f"{system.name}: built without it (System.with_jacobians)"
        raise ValueError(why)
    allowed = jvp_methods(backend.library.jvp_vi)
    if method_name not in allowed:
        raise ValueError(f"{system.name}: step_jvp takes {', '.join(allowed)}, not {method_name!r}")


def step_jvp(
    backend: Any,
    q: np.ndarray,
    w: np.ndarray,
    h: float,
    dq: np.ndarray,
    dw: np.ndarray,
    method_name: str,
    params: np.ndarray,
    options: Options | None = None,
    t: float = 0.0,
    u: np.ndarray | None = None,
) -> StepTangent:
    """One step of `method_name` from (q, w) with its tangent along (dq, dw) (each of shape
    (n, 3)) on a `CBackend` whose module has step_jvp(), at the parameters `params`, with the
    step's `options` (Newton's, for the VI; None: the defaults); or on the reference backend
    (one complex step through its own step, `s2gen.reference.step_jacobian.step_jvp`: every
    method `linearize` takes there, closed or driven, from time t with the inputs u held,
    None: the spec's). The C's step_jvp() covers closed systems, whose step does not depend
    on t and which have no inputs.

    Example:
        >>> from s2gen.runtime.reference_backend import ReferenceBackend
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> be = ReferenceBackend(s)
        >>> st = step_jvp(be, s.q0, s.omega0, 0.01, s.q0, 0 * s.omega0, "vi",
        ...               be.default_params())
        >>> st.dq.shape
        (2, 3)
    """
    system = backend.system
    n = system.n
    if u is not None:
        u = np.asarray(u, dtype=float).reshape(len(system.inputs.names))
    if backend.name == "reference":
        opts = Options() if options is None else options
        p = np.asarray(params, dtype=float)
        return StepTangent(*backend.step_jvp(method_name, t, h, q, w, dq, dw, u, p, opts))
    _refuse(backend, method_name)

    def state(x: np.ndarray) -> np.ndarray:
        return contiguous(np.asarray(x, dtype=float).reshape(n, 3))

    qn, wn, dqn, dwn = (np.empty((n, 3)) for _ in range(4))
    work = np.zeros(backend.library.jvp_work)
    opt = backend.library.options(Options() if options is None else options)
    status = backend.library.fn["step_jvp"](
        contiguous(params),
        ctypes.byref(opt),
        method(method_name).code,
        float(h),
        state(q),
        state(w),
        state(dq),
        state(dw),
        qn,
        wn,
        dqn,
        dwn,
        work,
    )
    if status != 0:
        st = Status(status)
        raise ValueError(f"{system.name}: step_jvp: {st.c_name}: {st.message}")
    return StepTangent(qn, wn, dqn, dwn)
