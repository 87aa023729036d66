"""The reference backend: the independent NumPy integrators of `s2gen.reference`.

Input: a `System`. Output: a backend object with the same `integrate` contract as the emitted
ones; failures come back as the status of the reference's typed error.

Example:
    >>> from s2gen.systems import builtin
    >>> ReferenceBackend(builtin("double_pendulum")).name
    'reference'
"""

from __future__ import annotations

from typing import Any

import numpy as np

from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = ["ReferenceBackend"]


class ReferenceBackend:
    """The independent NumPy reference integrator (`s2gen.reference`)."""

    name = "reference"

    def __init__(self, system: System) -> None:
        self.system = system
        self._problems: dict[tuple[float, ...], Any] = {}
        self._monitors: dict[tuple[float, ...], Any] = {}

    def default_params(self) -> np.ndarray:
        return np.array(self.system.parameter_values, dtype=float)

    def _problem(self, params: np.ndarray) -> Any:
        from s2gen import reference

        key = tuple(float(v) for v in params)
        if key not in self._problems:
            self._problems[key] = reference.problem_from_system(self.system, key)
        return self._problems[key]

    def _monitor(self, method: str, params: np.ndarray) -> Any:
        """The pair monitor of a time-transformed method (None for the others)."""
        from s2gen.methods import Family
        from s2gen.methods import method as method_row
        from s2gen.reference.adaptive import monitor_from_system

        if method_row(method).family is not Family.TIME_VI:
            return None
        key = tuple(float(v) for v in params)
        if key not in self._monitors:
            self._monitors[key] = monitor_from_system(self.system, key)
        return self._monitors[key]

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        from s2gen import reference

        return float(reference.energy(self._problem(params), q, w))

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray:
        return np.asarray(self._problem(params).grad(np.asarray(q, dtype=float)))

    def rhs(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        from s2gen import reference

        return reference.continuous_rhs(self._problem(params), q, w)

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        from s2gen import reference

        return np.asarray(reference.angular_momentum(self._problem(params), q, w))

    def step_jacobian(
        self,
        method: str,
        t: float,
        h: float,
        q: np.ndarray,
        w: np.ndarray,
        u: np.ndarray | None,
        params: np.ndarray,
        options: Options,
    ) -> tuple[np.ndarray, ...]:
        """(q+, w+, A, B, P) of one step in the embedding coordinates, as the C and NumPy
        modules' step_jacobian(), by the complex-step derivative of the reference's own step
        (`s2gen.reference.step_jacobian`); u None: the spec's inputs.

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> be = ReferenceBackend(s)
            >>> qn, wn, A, B, P = be.step_jacobian("vi", 0.0, 0.01, s.q0, s.omega0, None,
            ...                                    be.default_params(), Options())
            >>> A.shape, P.shape
            ((12, 12), (12, 5))
        """
        from s2gen.methods import Status
        from s2gen.reference import ReferenceIntegrationError
        from s2gen.reference.step_jacobian import step_jacobian

        try:
            return step_jacobian(
                self.system, method, t, h, q, w, u, params, options.newton_tol,
                options.newton_maxiter,
            )  # fmt: skip
        except (ReferenceIntegrationError, np.linalg.LinAlgError) as exc:
            st = exc.status if isinstance(exc, ReferenceIntegrationError) else Status.SINGULAR
            raise ValueError(
                f"{self.system.name}: step_jacobian: {st.c_name}: {st.message}"
            ) from exc

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
        every: int = 1,
        with_energy: bool = True,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray | None, dict[str, int]]:
        """The reference integrates every step; the stride is applied to its samples (it is
        the yardstick, not a fast path)."""
        from s2gen import reference

        samples = nsteps // every + 1
        monitor = self._monitor(method, params)
        stride = every if monitor is None else 1  # a time-transformed run samples the grid itself
        try:
            tr = reference.integrate(
                self._problem(params),
                method,
                q0,
                w0,
                h,
                nsteps,
                rtol=options.rtol,
                atol=options.atol,
                control=options.control,
                newton_tol=options.newton_tol,
                newton_maxiter=options.newton_maxiter,
                monitor=monitor,
                every=every,
            )
            en = tr.energy[::stride] if with_energy else None
            return 0, tr.q[::stride], tr.omega[::stride], en, dict(tr.stats)
        except reference.ReferenceIntegrationError as exc:
            n = self.system.n
            q = np.full((samples, n, 3), np.nan)
            w = np.full((samples, n, 3), np.nan)
            en = np.full(samples, np.nan)
            k = 0
            if exc.partial is not None:
                kept = slice(0, len(exc.partial.t), stride)
                k = len(exc.partial.t[kept])
                q[:k], w[:k] = exc.partial.q[kept], exc.partial.omega[kept]
                en[:k] = exc.partial.energy[kept]
            return int(exc.status), q, w, en if with_energy else None, {"fail_step": k}
