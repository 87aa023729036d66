"""The NumPy backend: the emitted NumPy module, cached by content hash and imported.

Input: a `System`. Output: a backend object with the same methods as the C backend.

Example:
    >>> from s2gen.systems import builtin
    >>> NumpyBackend(builtin("double_pendulum")).name
    'numpy'
"""

from __future__ import annotations

import hashlib
import importlib.util
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

from s2gen.build import cache_dir
from s2gen.emit import emit
from s2gen.methods import CONTROLS, Driver, method
from s2gen.monitor import emitted_refusal
from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = ["NumpyBackend", "import_cached"]


def import_cached(fname: str, text: str) -> ModuleType:
    """Write a generated Python module to the cache folder under its content hash; import it."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:24]
    path = cache_dir() / f"{Path(fname).stem}_{digest}.py"
    if not path.exists() or path.read_text() != text:
        tmp = path.with_suffix(f".{digest}.tmp")
        tmp.write_text(text)
        tmp.replace(path)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class NumpyBackend:
    """The emitted NumPy module, written to the cache folder by content hash and imported."""

    name = "numpy"

    def __init__(self, system: System) -> None:
        self.system = system
        ((fname, text),) = emit(system, "numpy").items()
        self.module = import_cached(fname, text)

    def default_params(self) -> np.ndarray:
        return np.array(self.system.parameter_values, dtype=float)

    @property
    def jacobian(self) -> bool:
        """Whether the module has step_jacobian() and field_jacobian() (emitted from
        `System.with_jacobians`).

        Example:
            >>> from s2gen.systems import builtin
            >>> NumpyBackend(builtin("double_pendulum").with_jacobians()).jacobian
            True
        """
        return hasattr(self.module, "step_jacobian")

    @property
    def jacobian_vi(self) -> bool:
        """Whether step_jacobian() differentiates the VI family too (as the C's JACOBIAN_VI)."""
        return self.jacobian and bool(self.module.JACOBIAN_VI)

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        return float(self.module.energy(params, q, w))

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.gradient(params, q))

    def rhs(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        return tuple(np.asarray(a) for a in self.module.rhs(params, q, w))

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.angular_momentum(params, q, w))

    def integrate(
        self,
        method_name: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
        every: int = 1,
        with_energy: bool = True,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray | None, dict[str, int]]:
        if method(method_name).driver is Driver.TIME_TRANSFORMED:
            self._check_transformed()
        return self.module.integrate(  # type: ignore[no-any-return]
            params,
            method(method_name).code,
            h,
            nsteps,
            q0,
            w0,
            rtol=options.rtol,
            atol=options.atol,
            control=CONTROLS.index(options.control),
            hmax=options.hmax,
            newton_tol=options.newton_tol,
            newton_maxiter=options.newton_maxiter,
            every=every,
            unit_tol=options.unit_tol,
            with_energy=with_energy,
            max_steps=options.max_steps,
        )

    def _check_transformed(self) -> None:
        """Refuse, in one line, the time-transformed methods for a system whose emitted module
        has no driver for them, as the C backend does (checked once per backend)."""
        if not hasattr(self, "_transformed_refusal"):
            self._transformed_refusal = emitted_refusal(self.system)
        if self._transformed_refusal is not None:
            raise ValueError(self._transformed_refusal)

    def integrate_driven(
        self,
        method_name: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
        t0: float = 0.0,
        inputs: np.ndarray | None = None,
        every: int = 1,
        feedback: Callable[[float, np.ndarray, np.ndarray], np.ndarray] | None = None,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, int]]:
        """One call of a driven module's integrate(), as `CBackend.integrate_driven`: from
        (q0, w0) at t0, `inputs` of shape (nsteps, n_inputs) held over each step (None: the
        defaults), or `feedback(t, q, w)` returning them from the state at each step's start
        (called once per step); (status, q, w, energy, work, stats), the samples after a
        failure NaN.

        Example:
            >>> from s2gen.spec import define_system
            >>> from s2gen.runtime.options import Options
            >>> s = define_system(name="spin", bodies=1, parameters={}, inputs={"tau": 1.0},
            ...                   diagonal=["2"], potential=0,
            ...                   forces={"F1": "tau*cross(e3, q1)"})
            >>> be, q0 = NumpyBackend(s), np.array([[1.0, 0, 0]])
            >>> st, q, w, e, W, _ = be.integrate_driven("vi", 0.01, 100, q0, 0 * q0,
            ...     be.default_params(), Options(), inputs=np.full((100, 1), 4.0))
            >>> st, round(float(w[-1, 0, 2]), 12), bool(abs(e[-1] - e[0] - W[-1]) < 1e-3)
            (0, 2.0, True)
        """
        u = None if inputs is None else np.asarray(inputs, dtype=float)
        if u is not None and u.shape != (nsteps, len(self.system.inputs.names)):
            raise ValueError(
                f"{self.system.name}: inputs of shape {u.shape}, expected "
                f"({nsteps}, {len(self.system.inputs.names)}): one row of inputs per step"
            )
        return self.module.integrate(  # type: ignore[no-any-return]
            params,
            method(method_name).code,
            t0,
            h,
            nsteps,
            q0,
            w0,
            u=u,
            feedback=feedback,
            newton_tol=options.newton_tol,
            newton_maxiter=options.newton_maxiter,
            every=every,
            unit_tol=options.unit_tol,
        )
