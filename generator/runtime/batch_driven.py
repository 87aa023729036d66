"""Batches of driven systems on the C backend: K members per call of integrate_batch(), each
with its own parameters, initial state and input schedule, from one start time t0.

Input: a `CBackend` of a driven system whose module carries integrate_batch()
(`System.with_batch`, `s2gen.parts.batch_driven`), the members' initial states (K, n, 3),
parameter vectors (K, NPARAMS) and inputs: None (the spec's defaults), one schedule of shape
(nsteps, n_inputs) for every member, or one per member, shape (K, nsteps, n_inputs). Output: a
`DrivenBatch`, the `Batch` record with the work done W. State feedback (a callable) is refused
in one line: integrate() takes it, one member at a time.

Example:
    >>> from s2gen.spec import define_system
    >>> from s2gen.runtime.c import CBackend
    >>> s = define_system(name="spin", bodies=1, parameters={"k": 1.0}, inputs={"tau": 1.0},
    ...                   diagonal=["2"], potential=0, forces={"F1": "k*tau*cross(e3, q1)"})
    >>> be = CBackend(s.with_batch())
    >>> q0 = np.array([[[1.0, 0, 0]]] * 2)
    >>> u = member_inputs(s, [[[4.0]] * 100, [[2.0]] * 100], 2, 100)
    >>> b = integrate_driven_batch(be, "vi", 0.0, 0.01, 100, q0, 0 * q0, np.ones((2, 1)), u,
    ...                            Options())
    >>> b.status.tolist(), np.round(b.omega[:, -1, 0, 2], 12).tolist()
    ([0, 0], [2.0, 1.0])
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.methods import method
from s2gen.runtime.batch import Batch, BatchCall
from s2gen.runtime.c import CBackend, contiguous, pointer
from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = ["DrivenBatch", "integrate_driven_batch", "member_inputs"]


@dataclass(frozen=True)
class DrivenBatch(Batch):
    """A driven system's batch: `Batch`'s arrays and W (K, samples), the work the forces and
    the input changes did on each member since t0 (E_k - E_0 - W_k is its energy-balance
    error); t counts from t0."""

    W: np.ndarray | None = None


def member_inputs(system: System, inputs: Any, K: int, nsteps: int) -> np.ndarray | None:
    """The members' input schedules, member-innermost as integrate_batch() reads them (shape
    (nsteps, n_inputs, K)), or None for the defaults: `inputs` is None, one schedule of shape
    (nsteps, n_inputs) for all members or one per member (K, nsteps, n_inputs); a one-line
    ValueError for a callable (state feedback) or another shape.

    Example:
        >>> from s2gen.spec import define_system
        >>> s = define_system(name="p", bodies=1, parameters={}, inputs={"a": 0.0},
        ...                   diagonal=["1"], potential="a*q1[2]")
        >>> member_inputs(s, [[1.0], [2.0]], 3, 2).shape
        (2, 1, 3)
        >>> member_inputs(s, np.ones((2, 2, 1)), 3, 2)
        Traceback (most recent call last):
        ...
        ValueError: integrate_batch: inputs of shape (2, 2, 1): expected (2, 1) for every member or (3, 2, 1), one row of the 1 inputs (a) per step and member
    """
    if inputs is None:
        return None
    if callable(inputs):
        raise ValueError(  # noqa: TRY004 (a refused argument is a ValueError, as elsewhere)
            "integrate_batch: inputs are schedules (arrays), not state feedback; integrate() "
            "takes a feedback function, one member at a time"
        )
    names = system.inputs.names
    try:
        u = np.asarray(inputs, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("integrate_batch: inputs must be an array of numbers") from None
    one, each = (nsteps, len(names)), (K, nsteps, len(names))
    if u.shape == one:
        u = np.broadcast_to(u, each)
    elif u.shape != each:
        raise ValueError(
            f"integrate_batch: inputs of shape {u.shape}: expected {one} for every member or "
            f"{each}, one row of the {len(names)} inputs ({', '.join(names)}) per step and "
            "member"
        )
    return contiguous(u.transpose(1, 2, 0))


def integrate_driven_batch(
    be: CBackend,
    method_name: str,
    t0: float,
    h: float,
    nsteps: int,
    q0: np.ndarray,
    w0: np.ndarray,
    params: np.ndarray,
    u: np.ndarray | None,
    options: Options,
    every: int = 1,
    with_energy: bool = True,
) -> DrivenBatch:
    """One call of a driven module's integrate_batch() for the K members (q0[k], w0[k],
    params[k]) with the member-innermost input schedules `u` (`member_inputs`)."""
    lib = be.library
    if not lib.batch:
        raise ValueError(f"{be.system.name}: the module has no integrate_batch()")
    call = BatchCall.of(be, q0, w0, params, nsteps, every, with_energy, extra=1)
    code = be._fn["integrate_batch"](
        call.K,
        call.p,
        ctypes.byref(lib.options(options, every)),
        method(method_name).code,
        t0,
        h,
        nsteps,
        pointer(u),
        call.q0,
        call.w0,
        call.q,
        call.w,
        pointer(call.energy),
        pointer(call.extra[0]),
        call.work,
        call.stats,
        call.status,
    )
    t = t0 + h * every * np.arange(call.samples)
    return DrivenBatch(**call.members(lib, code, t), W=call.extra[0].T)
