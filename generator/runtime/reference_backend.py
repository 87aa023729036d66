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
        self._steppers: dict[tuple[Any, ...], Any] = {}  # state_jacobian's steps

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
        from s2gen.methods import Driver
        from s2gen.methods import method as method_row
        from s2gen.reference.adaptive import monitor_from_system

        if method_row(method).driver is not Driver.TIME_TRANSFORMED:
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

    def _call(self, what: str, fun: Any, *args: Any) -> Any:
        """fun(*args), a failed reference step or a singular A(q) raised as a one-line
        ValueError naming the status, as the emitted modules report it."""
        from s2gen.methods import Status
        from s2gen.reference import ReferenceIntegrationError

        try:
            return fun(*args)
        except (ReferenceIntegrationError, np.linalg.LinAlgError) as exc:
            st = exc.status if isinstance(exc, ReferenceIntegrationError) else Status.SINGULAR
            raise ValueError(f"{self.system.name}: {what}: {st.c_name}: {st.message}") from exc

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
        from s2gen.reference.step_jacobian import step_jacobian

        tol, most = options.newton_tol, options.newton_maxiter
        args = (self.system, method, t, h, q, w, u, params, tol, most)
        return tuple(self._call("step_jacobian", step_jacobian, *args))

    def state_jacobian(
        self,
        method: str,
        t: float,
        h: float,
        q: np.ndarray,
        w: np.ndarray,
        u: np.ndarray | None,
        params: np.ndarray,
        options: Options,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q+, w+, A) of one step, `step_jacobian` without B and P (the step of `method` at
        these parameters and options built once and kept, for a run of many steps).

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> be = ReferenceBackend(s)
            >>> qn, wn, A = be.state_jacobian("rk4", 0.0, 0.01, s.q0, s.omega0, None,
            ...                               be.default_params(), Options())
            >>> A.shape
            (12, 12)
        """
        from s2gen.reference.step_jacobian import _inputs, reference_stepper, state_jacobian

        tol, most = options.newton_tol, options.newton_maxiter
        key = (method, tuple(float(v) for v in params), tol, most)
        if key not in self._steppers:
            self._steppers[key] = reference_stepper(self.system, method, params, tol, most)
        stepper = self._steppers[key]

        def step(qa: np.ndarray, wa: np.ndarray, ua: np.ndarray) -> tuple[np.ndarray, ...]:
            return stepper(qa, wa, t, h, ua)  # type: ignore[no-any-return]

        x = np.concatenate([np.ravel(q), np.ravel(w)]).astype(float)
        uu = _inputs(self.system, u)
        return self._call("step_jacobian", state_jacobian, step, x, uu, self.system.n)  # type: ignore[no-any-return]

    def step_jvp(
        self,
        method: str,
        t: float,
        h: float,
        q: np.ndarray,
        w: np.ndarray,
        dq: np.ndarray,
        dw: np.ndarray,
        u: np.ndarray | None,
        params: np.ndarray,
        options: Options,
    ) -> tuple[np.ndarray, ...]:
        """(q+, w+, dq+, dw+) of one step and its derivative along (dq, dw) (embedding
        coordinates), by one complex step through the reference's own step
        (`s2gen.reference.step_jacobian.step_jvp`); u None: the spec's inputs.

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> be = ReferenceBackend(s)
            >>> qn, wn, dqn, dwn = be.step_jvp("vi", 0.0, 0.01, s.q0, s.omega0, s.q0,
            ...                                0 * s.omega0, None, be.default_params(), Options())
            >>> dqn.shape
            (2, 3)
        """
        from s2gen.reference.step_jacobian import step_jvp

        tol, most = options.newton_tol, options.newton_maxiter
        args = (self.system, method, t, h, q, w, dq, dw, u, params, tol, most)
        return tuple(self._call("step_jvp", step_jvp, *args))

    def field_jacobian(
        self, params: np.ndarray, t: float, q: np.ndarray, w: np.ndarray, u: np.ndarray | None
    ) -> tuple[np.ndarray, ...]:
        """(qdot, wdot, J, Ju, Jp) of the continuous field in the embedding coordinates, as the
        C and NumPy modules' field_jacobian(), by the complex-step derivative of the reference's
        own field (`s2gen.reference.field_jacobian`); u None: the spec's inputs.

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> be = ReferenceBackend(s)
            >>> qd, wd, J, Ju, Jp = be.field_jacobian(be.default_params(), 0.0, s.q0,
            ...                                       s.omega0, None)
            >>> J.shape, Jp.shape
            ((12, 12), (12, 5))
        """
        from s2gen.reference.field_jacobian import field_jacobian

        return tuple(self._call("field_jacobian", field_jacobian, self.system, t, q, w, u, params))

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
                hmax=options.hmax if options.hmax > 0.0 else None,  # 0: the control's default
                newton_tol=options.newton_tol,
                newton_maxiter=options.newton_maxiter,
                monitor=monitor,
                every=every,
                max_steps=options.max_steps,
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
