"""A system compiled for one backend, with parameters by name: integrate, step, evaluate.

Input: a `System` and a backend name. Output: a `Model` whose methods integrate (returning a
`Trajectory`), take single steps and evaluate the energy, the potential's gradient and the
angular momentum; parameters are given by name and default to the spec's values.

Example:
    >>> from s2gen.systems import builtin
    >>> model = Model(builtin("double_pendulum"))
    >>> tr = model.integrate(h=0.01, T=0.05, params={"g": 1.0})
    >>> tr.q.shape, round(model.energy(tr.q[0], tr.omega[0], params={"g": 1.0}), 6)
    ((6, 2, 3), 100.675125)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from s2gen.runtime import get_backend, run
from s2gen.runtime.inputs import parameter_vector
from s2gen.runtime.model_jacobians import JacobianMethods
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import Trajectory
from s2gen.system import System

if TYPE_CHECKING:
    from s2gen.runtime.batch import Batch
    from s2gen.runtime.jvp import StepTangent
    from s2gen.runtime.linearize import Linearization
    from s2gen.runtime.stepper import Stepper

__all__ = ["Model"]

#: The options of a step given none (one object, so that its C struct is built once).
_DEFAULT_OPTIONS = Options()


class Model(JacobianMethods):
    """`system` compiled for `backend` ("c", "numpy" or "reference")."""

    def __init__(
        self,
        system: System,
        backend: str = "c",
        files: dict[str, str] | None = None,
        opt: str | None = None,
    ) -> None:
        """`files`: the emitted C to build (backend "c" only), for a process that must not
        derive the system itself; by default the system's own emitted files. `opt`: the C
        library's flag set, "portable" or "native" (`s2gen.build.FLAG_SETS`; default the
        environment's S2GEN_OPT, else "portable")."""
        self.system = system
        self.backend_name = backend
        if (files is not None or opt is not None) and backend != "c":
            raise ValueError(f"files and opt are for the C backend, not {backend!r}")
        if files is None and opt is None:
            self._backend = get_backend(system, backend)
        else:
            from s2gen.runtime.c import CBackend

            self._backend = CBackend(system, files, opt)
        self._steps: Any = None
        self._jacobians: Any = None  # the backend with step_jacobian(), once linearize asks
        self._batch: Any = None  # the C backend with integrate_batch(), once asked for
        self._opt = opt
        if backend in ("c", "numpy") and not system.driven:
            from s2gen.runtime.step_cache import StepCache

            self._steps = StepCache(self._backend)

    @property
    def parameters(self) -> dict[str, float]:
        """The spec's parameter values by name (the defaults of every call)."""
        return self.system.parameters

    def params(
        self, params: Mapping[str, float] | Sequence[float] | np.ndarray | None = None
    ) -> np.ndarray:
        """The parameter vector in declared order: defaults overridden by `params` (by name),
        or all values in declared order; ValueError for an unknown name, a wrong count or a
        value that is not a finite number.

        Example:
            >>> from s2gen.systems import builtin
            >>> Model(builtin("double_pendulum")).params({"g": 1.0}).tolist()
            [1.0, 1.0, 9.81, 9.81, 1.0]
        """
        return parameter_vector(self.system, params)

    def integrate(
        self,
        method: str = "vi",
        h: float | None = None,
        T: float | None = None,
        q0: np.ndarray | None = None,
        omega0: np.ndarray | None = None,
        options: Options | None = None,
        params: Mapping[str, float] | Sequence[float] | None = None,
        every: int = 1,
        energy: bool = True,
        t0: float = 0.0,
        inputs: Any = None,
    ) -> Trajectory:
        """Integrate from (q0, omega0) (default: the spec's) at t0 over T with step h, keeping
        every `every`-th sample and, with `energy`, its energy and angular momentum; a driven
        system's `inputs` as `simulate` takes them."""
        return run(
            self._backend,
            method,
            h=h,
            T=T,
            options=options,
            params=self.params(params),
            q0=q0,
            omega0=omega0,
            every=every,
            energy=energy,
            t0=t0,
            inputs=inputs,
        )

    def integrate_batch(
        self,
        method: str = "vi",
        h: float | None = None,
        T: float | None = None,
        q0: np.ndarray | None = None,
        omega0: np.ndarray | None = None,
        params: Mapping[str, Any] | None = None,
        every: int = 1,
        energy: bool = True,
        options: Options | None = None,
        t0: float = 0.0,
        inputs: Any = None,
    ) -> Batch:
        """K members at once, each with its own initial state (q0, omega0 of shape (K, n, 3);
        default: the spec's) and parameters (`params`: name -> K values, or one for all),
        through integrate_batch() (`s2gen.runtime.batch`): each member's samples, energy and
        statistics equal `integrate`'s for it bit for bit; a failing member stops alone (its
        status and stats say why and where). C backend, closed systems (M diagonal or coupled),
        the methods of `s2gen.parts.batch.BATCH_METHODS`; the first call builds the module
        with integrate_batch() (`System.with_batch`). The NumPy backend batches the members
        in its emitted module, vectorised over them (`s2gen.runtime.batch_numpy`; a diagonal
        or dense M, the methods of `numpy_batch_methods`), with the same record. A driven
        system (C backend, its driven methods) starts its members at `t0` with `inputs`: one
        schedule (steps, n_inputs) for all or one per member (K, steps, n_inputs), no
        feedback; its record, a `s2gen.runtime.batch_driven.DrivenBatch`, adds the work W.

        Example:
            >>> from s2gen.systems import builtin
            >>> b = Model(builtin("four_pendula")).integrate_batch(
            ...     "rk4", h=0.01, T=0.1, params={"g": [9.0, 9.5, 10.0]}, every=5)
            >>> b.q.shape, b.status.tolist()
            ((3, 3, 4, 3), [0, 0, 0])
        """
        from s2gen.parts.batch import batch_refusal
        from s2gen.runtime import check_run
        from s2gen.runtime.batch import integrate_batch, member_arrays
        from s2gen.runtime.c import CBackend

        if self.backend_name not in ("c", "numpy"):
            raise ValueError(
                f"integrate_batch: the C and NumPy backends only (not {self.backend_name!r})"
            )
        why = batch_refusal(self.system)
        if why is not None and not (self.system.driven and self.backend_name == "c"):
            raise ValueError(why)
        h = h if h is not None else self.system.run.h
        T = T if T is not None else self.system.run.T
        if h is None or T is None:
            raise ValueError(f"{self.system.origin}: no step size h or final time T given")
        opts = options or Options()
        nsteps = check_run(self.system, method, h, T, opts, every)
        qs, ws, p = member_arrays(self.system, q0, omega0, params)
        if not self.system.driven and (t0 != 0.0 or inputs is not None):
            raise ValueError(
                f"integrate_batch: {self.system.name} is closed: it takes no t0 or inputs"
            )
        if self.system.driven:
            from s2gen.runtime.batch_driven import integrate_driven_batch, member_inputs
            from s2gen.runtime.driven import check_driven_method

            check_driven_method(self.system, method)
            if not math.isfinite(t0):
                raise ValueError(f"integrate_batch: t0 = {t0!r}: must be a finite number")
            u = member_inputs(self.system, inputs, len(qs), nsteps)
            if self._batch is None:
                self._batch = CBackend(self.system.with_batch(), opt=self._opt)
            return integrate_driven_batch(
                self._batch, method, t0, h, nsteps, qs, ws, p, u, opts, every, energy
            )
        if self.backend_name == "numpy":
            from s2gen.runtime.batch_numpy import integrate_batch_numpy
            from s2gen.runtime.numpy_module import NumpyBackend

            if self._batch is None:
                self._batch = NumpyBackend(self.system.with_batch())
            return integrate_batch_numpy(
                self._batch, method, h, nsteps, qs, ws, p, opts, every, energy
            )
        if self._batch is None:
            self._batch = CBackend(self.system.with_batch(), opt=self._opt)
        return integrate_batch(self._batch, method, h, nsteps, qs, ws, p, opts, every, energy)

    def step(
        self,
        q: np.ndarray,
        omega: np.ndarray,
        h: float,
        method: str = "vi",
        options: Options | None = None,
        params: Mapping[str, float] | None = None,
        t: float = 0.0,
        u: Sequence[float] | np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """One step of size h from (q, omega); returns (q, omega) after it (no energy is kept,
        so the step is not checked for energy drift). The result is `integrate`'s: one step
        from a new state is a one-step run, and on the C and NumPy backends a run of calls,
        each from the state the last one returned with the same h, method, options and
        parameters, is `integrate` over those steps, bit for bit (the step function's warm
        start). There a fixed-step method from float64 arrays of shape (n, 3) costs one call
        of the emitted step and a few checks (`s2gen.runtime.step_cache`; the figures are
        `benchmarks/python_step.py`'s, and `stepper` is faster still); other calls run a
        one-step `integrate`, with the same checks and errors. A driven system's step starts
        at time t with the inputs u (default: the spec's) held over it.

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> model = Model(s)
            >>> q, w = s.q0, s.omega0
            >>> for _ in range(3):
            ...     q, w = model.step(q, w, 0.01)
            >>> bool((q == model.integrate(h=0.01, T=0.03).q[-1]).all())
            True
        """
        if self._steps is not None:
            done = self._steps.step(q, omega, h, method, options, params)
            if done is not None:
                return done
        inputs = None if u is None else np.reshape(np.asarray(u, dtype=float), (1, -1))
        if self.system.driven and self.backend_name == "c":
            done = self._driven_step(q, omega, h, method, options, params, t, inputs)
            if done is not None:
                return done
        tr = self.integrate(
            method, h, h, q, omega, options, params, energy=False, t0=t, inputs=inputs
        )
        return tr.q[-1], tr.omega[-1]

    def _driven_step(
        self,
        q: np.ndarray,
        omega: np.ndarray,
        h: float,
        method: str,
        options: Options | None,
        params: Mapping[str, float] | None,
        t: float,
        inputs: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """A driven system's step through the emitted step() when the arguments are plainly
        valid (else None: the checked one-step `integrate` decides, and reports a failure)."""
        from s2gen.methods import driven_methods

        n = self.system.n
        if method not in driven_methods() or not (isinstance(h, float) and h > 0.0):
            return None
        if not (isinstance(t, (int, float)) and math.isfinite(t)):
            return None
        qa, wa = _state(q), _state(omega)
        if qa.shape != (n, 3) or wa.shape != (n, 3):
            return None
        if not (np.all(np.isfinite(qa)) and np.all(np.isfinite(wa))):
            return None
        u = None
        if inputs is not None:
            u = np.ascontiguousarray(inputs.reshape(-1))
            if u.shape != (len(self.system.inputs.names),) or not np.all(np.isfinite(u)):
                return None
        try:
            p = self.params(params)
        except ValueError:
            return None
        status, qn, wn = self._backend.step_driven(  # type: ignore[attr-defined]
            method, h, qa, wa, p, options or _DEFAULT_OPTIONS, float(t), u
        )
        return (qn, wn) if status == 0 else None

    def linearize(
        self,
        q: np.ndarray,
        omega: np.ndarray,
        h: float,
        method: str = "rk4",
        t: float = 0.0,
        u: Sequence[float] | np.ndarray | None = None,
        basis: str = "tangent",
        params: Mapping[str, float] | None = None,
        options: Options | None = None,
    ) -> Linearization:
        """The exact derivatives of one step of an explicit Runge-Kutta method from (q, omega)
        at time t with the inputs u held (None: the spec's): A = dx+/dx, B = dx+/du and
        P = dx+/dp (one column per parameter, in the order of `System.parameter_names`, at
        `params`) in the tangent basis of T(S^2)^n (4n coordinates) or the embedding
        coordinates (6n), with the state after the step and the bases (`s2gen.runtime.linearize`); the VI family (M
        any M) and the fixed-step Runge-Kutta methods, C or NumPy backend (the first
        call builds the module with step_jacobian(), `System.with_jacobians`); on the
        reference backend the complex-step derivative of the reference's own step (the VI and
        RATTLE families, the fixed-step Runge-Kutta methods; `s2gen.reference.step_jacobian`).
        `options`: the step's (Newton's tolerance for a coupled M).

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("double_pendulum")
            >>> lin = Model(s).linearize(s.q0, s.omega0, 0.01, "rk4", basis="embedding")
            >>> lin.A.shape, bool((lin.q == Model(s).step(s.q0, s.omega0, 0.01, "rk4")[0]).all())
            ((12, 12), True)
        """
        from s2gen.runtime.linearize import linearize

        p = parameter_vector(self.system, params)
        uu = None if u is None else np.asarray(u, dtype=float)
        return linearize(self._jacobian_backend(), q, omega, h, method, p, t, uu, basis, options)

    def step_jvp(
        self,
        q: np.ndarray,
        omega: np.ndarray,
        h: float,
        dq: np.ndarray,
        domega: np.ndarray,
        method: str = "rk4",
        params: Mapping[str, float] | None = None,
        options: Options | None = None,
        t: float = 0.0,
        u: Sequence[float] | np.ndarray | None = None,
    ) -> StepTangent:
        """One step of a fixed-step method from (q, omega) and its exact directional
        derivative along (dq, domega) (embedding coordinates, shape (n, 3) each):
        A (dq, domega), A = `linearize`'s embedding A, without forming it, in O(n) time and
        memory (`s2gen.runtime.jvp`): the fixed-step Runge-Kutta methods and the VI family
        (vi, vi4, vi6, vi8, with Newton's `options`), for a diagonal M or a banded or
        max-index M with the structured solvers, closed, any n. C backend (the first call builds the
        module with step_jvp(), `System.with_jacobians`), or the reference backend: one
        complex step through its own step, every method and system its `linearize` takes,
        from time t with the inputs u held (None: the spec's; the C covers closed systems).

        Example:
            >>> from s2gen.systems import builtin
            >>> s = builtin("rope", n=100)
            >>> st = Model(s).step_jvp(s.q0, s.omega0, 1e-4, s.q0, 0 * s.omega0)
            >>> q1 = Model(s).step(s.q0, s.omega0, 1e-4, "rk4")[0]
            >>> st.domega.shape, float(abs(st.q - q1).max()) < 1e-14
            ((100, 3), True)
        """
        from s2gen.runtime.jvp import jvp_backend, step_jvp

        p = parameter_vector(self.system, params)
        uu = None if u is None else np.asarray(u, dtype=float)
        return step_jvp(jvp_backend(self), q, omega, h, dq, domega, method, p, options, t, uu)

    def stepper(
        self,
        method: str = "vi",
        h: float | None = None,
        q0: np.ndarray | None = None,
        omega0: np.ndarray | None = None,
        options: Options | None = None,
        params: Mapping[str, float] | Sequence[float] | None = None,
        t0: float = 0.0,
    ) -> Stepper:
        """A run of a fixed-step method (not RK45 or DOP853) from (q0, omega0) (default: the
        spec's) at time t0, stepped in place by `advance()` (`s2gen.runtime.stepper`): on the
        C backend one C call per step with no per-step check (the state is its own last
        output, checked when set), the fastest way to step from Python; on the NumPy backend
        one call of the module's `step`. Its steps are `integrate`'s, bit for bit, Newton
        iterations included; h defaults to the spec's [run] h. ValueError on the reference
        backend (it has no step function), for an adaptive method, or for what `integrate`
        refuses.

        Example:
            >>> from s2gen.systems import builtin
            >>> stepper = Model(builtin("double_pendulum")).stepper("rattle", h=0.01)
            >>> stepper.advance()
            >>> round(stepper.t, 12), stepper.q.shape
            (0.01, (2, 3))
        """
        from s2gen.methods import check_method
        from s2gen.runtime import check_run
        from s2gen.runtime.stepper import make_stepper

        if self.system.driven:
            raise ValueError(
                f"{self.system.origin}: the stepper does not take driven systems yet; "
                "Model.step(q, omega, h, t=..., u=...) and Model.integrate(..., inputs=...) do"
            )
        if self._steps is None:
            raise ValueError(
                f"the {self.backend_name} backend has no step function: the stepper runs on "
                "the c and numpy backends (Model.step works on every backend)"
            )
        if check_method(method, self.backend_name).adaptive:
            raise ValueError(
                f"method {method!r} is adaptive: the stepper takes fixed-step methods "
                "(Model.integrate runs adaptive ones)"
            )
        h = h if h is not None else self.system.run.h
        if h is None:
            raise ValueError(f"{self.system.origin}: no step size h given (spec [run])")
        opts = options or Options()
        check_run(self.system, method, h, h, opts)
        if not isinstance(t0, (int, float, np.floating)) or not np.isfinite(t0):
            raise ValueError(f"t0 = {t0!r}: must be a finite number")
        return make_stepper(self._backend, method, h, self.params(params), opts, q0, omega0, t0)

    def energy(
        self, q: np.ndarray, omega: np.ndarray, params: Mapping[str, float] | None = None
    ) -> float:
        """Total energy (kinetic plus potential) of one state."""
        return float(self._backend.energy(_state(q), _state(omega), self.params(params)))

    def gradient(self, q: np.ndarray, params: Mapping[str, float] | None = None) -> np.ndarray:
        """dV/dq of one configuration, shape (n, 3)."""
        return np.asarray(self._backend.gradient(_state(q), self.params(params))).reshape(-1, 3)

    def angular_momentum(
        self, q: np.ndarray, omega: np.ndarray, params: Mapping[str, float] | None = None
    ) -> np.ndarray:
        """J = sum_i q_i x sum_j M_ij (omega_j x q_j) of one state, shape (3,)."""
        return np.asarray(
            self._backend.angular_momentum(_state(q), _state(omega), self.params(params))
        )


def _state(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(x, dtype=float).reshape(-1, 3))
