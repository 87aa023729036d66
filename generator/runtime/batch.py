"""Batches on the C backend: K members of one system per call of integrate_batch().

Input: a `CBackend` whose module carries integrate_batch() (`System.with_batch`), the members'
initial states (K, n, 3) and parameter vectors (K, NPARAMS). Output: a `Batch` record of
per-member arrays. The members' arrays cross the boundary member-innermost (the header's
layout, `s2gen.interface_batch`) and come back member-first.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.runtime.c import CBackend
    >>> s = builtin("four_pendula")
    >>> be = CBackend(s.with_batch())
    >>> q0 = np.repeat(s.q0[None], 3, axis=0)
    >>> w0 = np.repeat(s.omega0[None], 3, axis=0)
    >>> p = np.repeat(be.default_params()[None], 3, axis=0)
    >>> b = integrate_batch(be, "vi", 0.01, 10, q0, w0, p, Options(), every=5)
    >>> b.q.shape, b.status.tolist(), b.stats["steps"].tolist()
    ((3, 3, 4, 3), [0, 0, 0], [10, 10, 10])
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.methods import method
from s2gen.parts.batch import BATCH_METHODS
from s2gen.runtime.c import CBackend, contiguous, pointer
from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = ["Batch", "integrate_batch", "member_arrays"]


@dataclass(frozen=True)
class Batch:
    """The members of one batch, member first: times t (samples), q and omega (K, samples,
    n, 3), energy (K, samples; None when not asked for), status (K; 0 = OK, else the
    integrate() status of the member, `s2gen.methods.Status`) and stats (field -> array of
    K: steps, gradient_evals, fail_step, ...). A failed member's samples from
    stats["fail_step"][k] on are NaN. q, omega and energy are views of the member-innermost
    arrays the C wrote (no transposed copy: it would cost more than the integration when
    every sample is kept); copy what you keep of them."""

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray | None
    status: np.ndarray
    stats: dict[str, np.ndarray]


def integrate_batch(
    be: CBackend,
    method_name: str,
    h: float,
    nsteps: int,
    q0: np.ndarray,
    w0: np.ndarray,
    params: np.ndarray,
    options: Options,
    every: int = 1,
    with_energy: bool = True,
) -> Batch:
    """One call of integrate_batch() for the K members (q0[k], w0[k], params[k])."""
    lib = be.library
    if not lib.batch:
        raise ValueError(f"{be.system.name}: the module has no integrate_batch()")
    if method_name not in BATCH_METHODS:
        raise ValueError(
            f"integrate_batch: method {method_name!r} is not batched; batched methods: "
            f"{', '.join(BATCH_METHODS)}"
        )
    K, n = q0.shape[0], be.system.n
    samples = nsteps // every + 1
    # member-innermost: element e of member k at [e * K + k]
    qi = contiguous(q0.reshape(K, 3 * n).T)
    wi = contiguous(w0.reshape(K, 3 * n).T)
    pi = contiguous(params.reshape(K, -1).T)
    q = np.empty((samples, 3 * n, K))
    w = np.empty((samples, 3 * n, K))
    en = np.empty((samples, K)) if with_energy else None
    stats = (lib.Stats * K)()
    status = (ctypes.c_int * K)()
    work = np.zeros(max(1, lib.batch_work))
    code = be._fn["integrate_batch"](
        K,
        pi,
        ctypes.byref(lib.options(options, every)),
        method(method_name).code,
        h,
        nsteps,
        qi,
        wi,
        q,
        w,
        pointer(en),
        work,
        stats,
        status,
    )
    if code and not any(status):
        raise ValueError(f"integrate_batch: arguments refused (status {code})")
    per = [lib.stats(st) for st in stats]
    for k, st in enumerate(status):  # nothing written past a failure (or at all): NaN
        if st:
            for a in (q, w, en):
                if a is not None:
                    a[per[k]["fail_step"] :, ..., k] = np.nan
    return Batch(
        t=h * every * np.arange(samples),
        q=q.reshape(samples, n, 3, K).transpose(3, 0, 1, 2),
        omega=w.reshape(samples, n, 3, K).transpose(3, 0, 1, 2),
        energy=None if en is None else en.T,
        status=np.array(list(status), dtype=int),
        stats={f: np.array([s[f] for s in per]) for f in (per[0] if per else {})},
    )


def member_arrays(
    system: System,
    q0: np.ndarray | None,
    omega0: np.ndarray | None,
    params: Mapping[str, Any] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The members' (q0, omega0, parameter vectors), shapes (K, n, 3), (K, n, 3), (K,
    NPARAMS): K from q0, omega0 or the parameter arrays (which must agree); the spec's
    initial state and parameter values where not given; a one-line ValueError otherwise.

    Example:
        >>> from s2gen.systems import builtin
        >>> q, w, p = member_arrays(builtin("four_pendula"), None, None, {"g": [9.0, 9.5]})
        >>> q.shape, p[:, 2].tolist()
        ((2, 4, 3), [9.0, 9.5])
    """
    n, names = system.n, system.parameter_names
    sizes = {len(np.atleast_1d(v)) for v in (params or {}).values() if np.ndim(v) == 1}
    for a in (q0, omega0):
        if a is not None:
            sizes.add(np.shape(a)[0] if np.ndim(a) == 3 else -1)
    if len(sizes) != 1 or min(sizes) < 1:
        raise ValueError(
            "integrate_batch: give q0 and omega0 of shape (K, n, 3) and/or parameter arrays of "
            f"K values, one K for all (got {sorted(sizes) or 'none'})"
        )
    K = sizes.pop()
    unknown = sorted(set(params or {}) - set(names))
    if unknown:
        raise ValueError(f"integrate_batch: unknown parameter(s) {', '.join(unknown)}")
    p = np.repeat(np.array(system.parameter_values, dtype=float)[None], K, axis=0)
    for j, name in enumerate(names):
        if params and name in params:
            p[:, j] = np.broadcast_to(np.asarray(params[name], dtype=float), (K,))

    def state(a: np.ndarray | None, spec: np.ndarray | None, what: str) -> np.ndarray:
        if a is None:
            if spec is None:
                raise ValueError(
                    f"integrate_batch: {system.name} has no initial state: give {what}"
                )
            return np.repeat(np.asarray(spec, dtype=float)[None], K, axis=0)
        out = np.asarray(a, dtype=float)
        if out.shape != (K, n, 3):
            raise ValueError(
                f"integrate_batch: {what} of shape {out.shape}, expected ({K}, {n}, 3)"
            )
        return out

    return state(q0, system.q0, "q0"), state(omega0, system.omega0, "omega0"), p
