"""The methods of `Model` built on the step Jacobians' module: the field's Jacobian and
Lyapunov spectra (`Model.linearize` is in `s2gen.runtime.model`).

Input: a `Model` (its system, backend and parameters). Output: `FieldJacobian` and
`LyapunovSpectrum` records, from the C or NumPy module (the Model's backend) with
step_jacobian() and field_jacobian(), built once from `System.with_jacobians` when first
asked for.

Example:
    >>> from s2gen.runtime.model import Model
    >>> issubclass(Model, JacobianMethods)
    True
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from s2gen.runtime.inputs import parameter_vector
from s2gen.runtime.options import Options
from s2gen.system import System

if TYPE_CHECKING:
    from s2gen.runtime.field_jacobian import FieldJacobian
    from s2gen.runtime.lyapunov import LyapunovSpectrum

__all__ = ["JacobianMethods"]


class JacobianMethods:
    """`Model`'s methods on the module with Jacobians (a mixin: `Model` sets the attributes)."""

    system: System
    _backend: Any
    _jacobians: Any

    def _jacobian_backend(self) -> Any:
        """The backend with step_jacobian() and field_jacobian(): this one when it has them
        (the reference always does), else (C or NumPy) the module of the same backend built
        once from `System.with_jacobians` when first asked for."""
        from s2gen.equations.jacobian import jacobian_refusal
        from s2gen.runtime.c import CBackend
        from s2gen.runtime.linearize import jacobian_features
        from s2gen.runtime.numpy_module import NumpyBackend

        backend = self._backend
        if backend.name == "reference":
            return backend  # the complex-step derivatives of its own step and field
        if not jacobian_features(backend)[0]:
            why = jacobian_refusal(self.system)
            if why is not None:
                raise ValueError(f"{self.system.name}: {why}")
            if self._jacobians is None:
                kind = CBackend if isinstance(backend, CBackend) else NumpyBackend
                self._jacobians = kind(self.system.with_jacobians())
            backend = self._jacobians
        return backend

    def jacobian_field(
        self,
        q: np.ndarray,
        omega: np.ndarray,
        t: float = 0.0,
        u: Sequence[float] | np.ndarray | None = None,
        basis: str = "tangent",
        params: Mapping[str, float] | None = None,
    ) -> FieldJacobian:
        """The exact derivatives of the continuous field (qdot, omegadot) at (q, omega) at
        time t with the inputs u (None: the spec's): J = d/dx and Ju = d/du in the tangent
        basis (4n: the generator of `linearize`'s tangent A, A = I + hJ + O(h^2) for a
        Runge-Kutta step) or the embedding coordinates (6n), with the field and the basis
        (`s2gen.runtime.field_jacobian`); C or NumPy backend, as `linearize`, or the
        reference backend (the complex-step derivative of its own field).

        Example:
            >>> from s2gen.runtime.model import Model
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> fj = Model(s).jacobian_field(s.q0, s.omega0, basis="embedding")
            >>> fj.J.shape, fj.qdot.shape
            ((12, 12), (2, 3))
        """
        from s2gen.runtime.field_jacobian import jacobian_field

        p = parameter_vector(self.system, params)
        uu = None if u is None else np.asarray(u, dtype=float)
        return jacobian_field(self._jacobian_backend(), q, omega, p, t, uu, basis)

    def lyapunov(
        self,
        q: np.ndarray,
        omega: np.ndarray,
        h: float,
        T: float,
        method: str = "vi",
        transient: float = 0.0,
        t0: float = 0.0,
        u: Sequence[float] | np.ndarray | None = None,
        blocks: int = 10,
        samples: int = 400,
        params: Mapping[str, float] | None = None,
        options: Options | None = None,
        progress: Any = None,
    ) -> LyapunovSpectrum:
        """The Lyapunov spectrum of the steps of `method` (those `linearize` takes) from
        (q, omega) at t0 with the inputs u held: `transient` discarded, then T averaged, by QR
        re-orthonormalization of the step Jacobians in the tangent basis
        (`s2gen.runtime.lyapunov`): the exponents (4n, decreasing up to nearly equal ones)
        and their errors from `blocks` block means, the pair sums, the running estimates at
        `samples` times; `progress(fraction)` is called as the run goes. C or NumPy backend,
        as `linearize`, or the reference backend (its complex-step A: slow, a check).

        Example:
            >>> from s2gen.runtime.model import Model
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> ls = Model(s).lyapunov(s.q0, s.omega0, h=0.01, T=1.0)
            >>> ls.exponents.shape, ls.pair_sums.shape
            ((8,), (4,))
        """
        from s2gen.runtime.lyapunov import lyapunov

        p = parameter_vector(self.system, params)
        uu = None if u is None else np.asarray(u, dtype=float)
        return lyapunov(
            self._jacobian_backend(), q, omega, h, T, method, p, transient, t0, uu, blocks,
            samples, options, progress,
        )  # fmt: skip
