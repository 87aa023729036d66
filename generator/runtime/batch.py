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

__all__ = ["Batch", "BatchCall", "integrate_batch", "member_arrays"]


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
    call = BatchCall.of(be, q0, w0, params, nsteps, every, with_energy)
    code = be._fn["integrate_batch"](
        call.K,
        call.p,
        ctypes.byref(lib.options(options, every)),
        method(method_name).code,
        h,
        nsteps,
        call.q0,
        call.w0,
        call.q,
        call.w,
        pointer(call.energy),
        call.work,
        call.stats,
        call.status,
    )
    return Batch(**call.members(lib, code, h * every * np.arange(call.samples)))


@dataclass(frozen=True)
class BatchCall:
    """One call of a C integrate_batch(): the K members' initial states and parameter vectors
    laid out member-innermost (element e of member k at [e * K + k]), the output arrays it
    writes (samples, 3n, K) and its per-member stats and status. `extra` holds further
    per-sample outputs, shape (samples, K), that a failure cuts as the states (a driven
    module's work W)."""

    K: int
    n: int
    samples: int
    p: np.ndarray
    q0: np.ndarray
    w0: np.ndarray
    q: np.ndarray
    w: np.ndarray
    energy: np.ndarray | None
    extra: tuple[np.ndarray, ...]
    work: np.ndarray
    stats: Any
    status: Any

    @classmethod
    def of(
        cls,
        be: CBackend,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        nsteps: int,
        every: int,
        with_energy: bool,
        extra: int = 0,
    ) -> BatchCall:
        """The buffers of a call for the members (q0[k], w0[k], params[k]), with `extra`
        per-sample outputs."""
        lib, K, n = be.library, q0.shape[0], be.system.n
        samples = nsteps // every + 1
        return cls(
            K=K,
            n=n,
            samples=samples,
            p=contiguous(params.reshape(K, -1).T),
            q0=contiguous(q0.reshape(K, 3 * n).T),
            w0=contiguous(w0.reshape(K, 3 * n).T),
            q=np.empty((samples, 3 * n, K)),
            w=np.empty((samples, 3 * n, K)),
            energy=np.empty((samples, K)) if with_energy else None,
            extra=tuple(np.empty((samples, K)) for _ in range(extra)),
            work=np.zeros(max(1, lib.batch_work)),
            stats=(lib.Stats * K)(),
            status=(ctypes.c_int * K)(),
        )

    def members(self, lib: Any, code: int, t: np.ndarray) -> dict[str, Any]:
        """The `Batch` fields after the call returned `code` (a one-line ValueError when it
        refused its arguments): each failed member's samples from its fail_step on are NaN
        (nothing was written there), in the states, the energy and the extra outputs."""
        if code and not any(self.status):
            raise ValueError(f"integrate_batch: arguments refused (status {code})")
        per = [lib.stats(st) for st in self.stats]
        for k, st in enumerate(self.status):
            if st:
                for a in (self.q, self.w, self.energy, *self.extra):
                    if a is not None:
                        a[per[k]["fail_step"] :, ..., k] = np.nan
        n, K, samples = self.n, self.K, self.samples
        return {
            "t": t,
            "q": self.q.reshape(samples, n, 3, K).transpose(3, 0, 1, 2),
            "omega": self.w.reshape(samples, n, 3, K).transpose(3, 0, 1, 2),
            "energy": None if self.energy is None else self.energy.T,
            "status": np.array(list(self.status), dtype=int),
            "stats": {f: np.array([s[f] for s in per]) for f in (per[0] if per else {})},
        }


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
