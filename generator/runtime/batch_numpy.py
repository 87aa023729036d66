"""Batches on the NumPy backend: K members of one system per call of the emitted module's
integrate_batch().

Input: a `NumpyBackend` whose module was emitted from `System.with_batch`, the members'
initial states (K, n, 3) and parameter vectors (K, NPARAMS). Output: the `Batch` record of
the C backend (`s2gen.runtime.batch`), each member's arrays equal to the NumPy integrate()'s
for it. The members' code is emitted into the NumPy module (`s2gen.printing.numpy_batch`
says why there); this module only checks what it covers and wraps its result.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.runtime.numpy_module import NumpyBackend
    >>> s = builtin("four_pendula")
    >>> be = NumpyBackend(s.with_batch())
    >>> q0 = np.repeat(s.q0[None], 3, axis=0)
    >>> w0 = np.repeat(s.omega0[None], 3, axis=0)
    >>> p = np.repeat(be.default_params()[None], 3, axis=0)
    >>> b = integrate_batch_numpy(be, "vi", 0.01, 10, q0, w0, p, Options(), every=5)
    >>> b.q.shape, b.status.tolist(), b.stats["steps"].tolist()
    ((3, 3, 4, 3), [0, 0, 0], [10, 10, 10])
"""

from __future__ import annotations

import numpy as np

from s2gen.methods import method
from s2gen.parts.batch import BATCH_METHODS
from s2gen.runtime.batch import Batch
from s2gen.runtime.numpy_module import NumpyBackend
from s2gen.runtime.options import Options

__all__ = ["integrate_batch_numpy", "numpy_batch_methods"]


def numpy_batch_methods(be: NumpyBackend) -> tuple[str, ...]:
    """The methods the module's integrate_batch() takes (none when it has none).

    Example:
        >>> from s2gen.systems import builtin
        >>> numpy_batch_methods(NumpyBackend(builtin("double_pendulum").with_batch()))
        ('vi', 'vi4', 'vi6', 'vi8', 'rk2', 'rk2-proj', 'rk3', 'rk4')
        >>> numpy_batch_methods(NumpyBackend(builtin("dipoles").with_batch()))
        ()
    """
    codes = getattr(be.module, "BATCH_METHODS", ())
    return tuple(name for name in BATCH_METHODS if method(name).code in codes)


def integrate_batch_numpy(
    be: NumpyBackend,
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
    """One call of the NumPy module's integrate_batch() for the K members (q0[k], w0[k],
    params[k]); a one-line ValueError for a module or method it does not cover."""
    mod = be.module
    if not hasattr(mod, "BATCH_REFUSAL"):
        raise ValueError(f"{be.system.name}: the module has no integrate_batch()")
    if mod.BATCH_REFUSAL is not None:
        raise ValueError(mod.BATCH_REFUSAL)
    covered = numpy_batch_methods(be)
    if method_name not in covered:
        raise ValueError(
            f"integrate_batch: method {method_name!r} is not batched on the NumPy backend for "
            f"{be.system.name}; batched methods: {', '.join(covered)}"
        )
    status, q, w, en, stats = mod.integrate_batch(
        params,
        method(method_name).code,
        h,
        nsteps,
        q0,
        w0,
        every=every,
        unit_tol=options.unit_tol,
        with_energy=with_energy,
        newton_tol=options.newton_tol,
        newton_maxiter=options.newton_maxiter,
    )
    return Batch(
        t=h * every * np.arange(nsteps // every + 1),
        q=q,
        omega=w,
        energy=en,
        status=status,
        stats=stats,
    )
