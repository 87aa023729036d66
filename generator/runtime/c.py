"""The C backend: emitted C compiled (cached by content) and called through ctypes.

Input: a `System` (or prebuilt emitted files). Output: a backend object whose `integrate`
returns (status, q, omega, energy, stats) and whose `energy`, `gradient`, `rhs` and
`angular_momentum` evaluate single states with given parameters.

The ctypes prototypes and the options and statistics structs are built from the interface
records of `s2gen.interface`, the same records the headers are rendered from (`CLibrary`), so
the mirror of the C API cannot drift from it; the angle-form runtime uses the same loader.

Example:
    >>> from s2gen.systems import builtin
    >>> be = CBackend(builtin("double_pendulum"))
    >>> be.gradient(builtin("double_pendulum").q0, be.default_params()).shape
    (2, 3)
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from s2gen.build import BuildError, build_flags, header_macro, load_library
from s2gen.emit import emit
from s2gen.interface import Field, Interface, Kind, interface
from s2gen.ir import ModuleKind
from s2gen.methods import CONTROLS, Driver, Status, method
from s2gen.monitor import emitted_refusal
from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = ["CBackend", "CLibrary", "contiguous", "pointer"]

_DP = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_LP = np.ctypeslib.ndpointer(dtype=np.int_, flags="C_CONTIGUOUS")
_SCALARS = {Kind.DOUBLE: ctypes.c_double, Kind.INT: ctypes.c_int, Kind.LONG: ctypes.c_long}


_ARRAYS = (Kind.ARRAY, Kind.CONST_ARRAY, Kind.LONG_ARRAY)
#: Kinds passed as plain addresses when they may be NULL
_NULLABLE = (*_ARRAYS, Kind.FEEDBACK, Kind.POINTER)
_DPTR = ctypes.POINTER(ctypes.c_double)
#: A driven module's input callback: feedback(ctx, t, q, w, u) (see the emitted header).
FEEDBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_double, _DPTR, _DPTR, _DPTR)
#: Seconds between two progress reports of a run in a thread.
POLL_SECONDS = 0.2
#: A progress callback: the fraction of the run done, in [0, 1].
Progress = Callable[[float], None]


def pointer(a: np.ndarray | None) -> int | None:
    """The address of a contiguous array for a parameter that may be NULL (None: NULL)."""
    return None if a is None else int(a.ctypes.data)


def contiguous(a: np.ndarray) -> np.ndarray:
    """`a` as a C-contiguous float64 array (what the emitted functions take)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _struct(name: str, fields: tuple[Field, ...]) -> type[ctypes.Structure]:
    return type(
        name, (ctypes.Structure,), {"_fields_": [(f.name, _SCALARS[f.kind]) for f in fields]}
    )


class CLibrary:
    """An emitted C module compiled and loaded, its functions declared from the interface."""

    def __init__(
        self,
        files: dict[str, str],
        kind: ModuleKind,
        prefix: str,
        opt: str | None = None,
        driven: bool = False,
    ) -> None:
        header = files[f"{prefix}.h"]
        #: Whether the module has step_jacobian() (systems of a few bodies)
        self.jacobian = f"#define {prefix.upper()}_JACOBIAN_WORK_SIZE " in header
        #: Whether the module has integrate_batch() (`System.with_batch`)
        self.batch = f"#define {prefix.upper()}_BATCH_WORK_SIZE " in header
        #: Whether the module has step_jvp() (`s2gen.equations.jvp.has_jvp`)
        self.jvp = f"#define {prefix.upper()}_JVP_WORK_SIZE " in header
        self.api: Interface = interface(kind, driven, self.jacobian, self.batch, self.jvp)
        #: Doubles of step_jvp()'s workspace (0 without it)
        self.jvp_work = header_macro(header, prefix, "JVP_WORK_SIZE") if self.jvp else 0
        #: Whether step_jvp() takes the VI family too
        self.jvp_vi = self.jvp and header_macro(header, prefix, "JVP_VI") == 1
        #: Doubles of integrate_batch()'s workspace (0 without it)
        self.batch_work = header_macro(header, prefix, "BATCH_WORK_SIZE") if self.batch else 0
        self.lib, self.build = load_library(files, build_flags(opt))
        self.work = np.zeros(max(1, header_macro(header, prefix, "WORK_SIZE")))
        #: Doubles of step_jacobian()'s workspace (0 without it)
        self.jacobian_work = (
            header_macro(header, prefix, "JACOBIAN_WORK_SIZE") if self.jacobian else 0
        )
        #: Whether step_jacobian() differentiates the VI family too
        self.jacobian_vi = self.jacobian and header_macro(header, prefix, "JACOBIAN_VI") == 1
        names = {f.name for f in self.api.functions}
        #: Doubles of step()'s carry (0 for a module without step()).
        carry = "step" in names and not driven
        self.carry_size = header_macro(header, prefix, "STEP_CARRY") if carry else 0
        self.Options = _struct("Options", self.api.options)
        self.Stats = _struct("Stats", self.api.stats)
        self.Stepper = _struct("Stepper", self.api.stepper)
        self.spec_hash = ctypes.c_char_p(
            ctypes.addressof(ctypes.c_char.in_dll(self.lib, f"{prefix}_spec_hash"))
        ).value
        self.fn: dict[str, Any] = {}
        types = {
            Kind.CONST_ARRAY: _DP,
            Kind.ARRAY: _DP,
            Kind.VECTOR3: _DP,
            Kind.LONG_ARRAY: _LP,
            Kind.INT_OUT: ctypes.POINTER(ctypes.c_int),
            Kind.OPTIONS: ctypes.POINTER(self.Options),
            Kind.OPTIONS_OUT: ctypes.POINTER(self.Options),
            Kind.STATS: ctypes.POINTER(self.Stats),
            Kind.STEPPER: ctypes.POINTER(self.Stepper),
            Kind.FEEDBACK: FEEDBACK,
            Kind.POINTER: ctypes.c_void_p,
            **_SCALARS,
        }
        for f in self.api.functions:
            func = getattr(self.lib, f"{prefix}_{f.name}")
            func.restype = None if f.returns is Kind.VOID else _SCALARS[f.returns]
            func.argtypes = [
                ctypes.c_void_p if p.nullable and p.kind in _NULLABLE else types[p.kind]
                for p in f.params
            ]
            self.fn[f.name] = func

    def options(self, options: Options, every: int = 1) -> Any:
        """The emitted options struct filled from `options` and the output stride (fields the
        module lacks are skipped)."""
        opt = self.Options()
        self.fn["default_options"](ctypes.byref(opt))
        values = {
            "rtol": options.rtol,
            "atol": options.atol,
            "hmax": options.hmax,
            "control": CONTROLS.index(options.control),
            "newton_tol": options.newton_tol,
            "newton_maxiter": options.newton_maxiter,
            "unit_tol": options.unit_tol,
            "max_steps": options.max_steps,
            "every": every,
        }
        for f in self.api.options:
            if f.name in values:
                setattr(opt, f.name, values[f.name])
        return opt

    def stats(self, st: Any) -> dict[str, Any]:
        """The statistics struct as a dict (ints and floats)."""
        return {
            f.name: (float if f.kind is Kind.DOUBLE else int)(getattr(st, f.name))
            for f in self.api.stats
        }


class CBackend:
    """The emitted C of a system, compiled (cached) and loaded."""

    name = "c"

    def __init__(
        self, system: System, files: dict[str, str] | None = None, opt: str | None = None
    ) -> None:
        """Compile `files` (default: the system's emitted C) with flag set `opt` (see
        `s2gen.build.FLAG_SETS`; default S2GEN_OPT, else "portable") and load the library;
        `files` lets a process that never derived the system (a cluster worker) build it."""
        self.system = system
        files = emit(system, "c") if files is None else files
        self.library = CLibrary(files, ModuleKind.SPHERE, system.name, opt, system.driven)
        if self.library.spec_hash != system.spec_hash().encode():
            raise BuildError(
                f"{system.name}: the library was built from spec {self.library.spec_hash!r}, "
                f"not from this system's {system.spec_hash()!r}"
            )
        self.build = self.library.build
        self.work = self.library.work
        self._fn = self.library.fn

    def default_params(self) -> np.ndarray:
        return np.array(self.system.parameter_values, dtype=float)

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        return float(self._fn["energy"](contiguous(params), contiguous(q), contiguous(w)))

    def potential(self, q: np.ndarray, params: np.ndarray) -> float:
        return float(self._fn["potential"](contiguous(params), contiguous(q)))

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray:
        g = np.zeros(np.size(q))
        self._fn["gradient"](contiguous(params), contiguous(q), g)
        return g.reshape(np.shape(q))

    def rhs(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        dq, dw = np.zeros(np.size(q)), np.zeros(np.size(q))
        status = self._fn["rhs"](
            contiguous(params), contiguous(q), contiguous(w), dq, dw, self.work
        )
        if status:
            raise RuntimeError(Status(status).message)
        return dq.reshape(np.shape(q)), dw.reshape(np.shape(q))

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        out = np.zeros(3)
        self._fn["angular_momentum"](contiguous(params), contiguous(q), contiguous(w), out)
        return out

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
        feedback: Any = None,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One call of a driven module's integrate(): from (q0, w0) at t0, `inputs` of shape
        (nsteps, n_inputs) held over each step (None: the defaults), or a `FEEDBACK` function
        that writes them from the state; (status, q, w, energy, work, stats), the samples
        after a failure NaN.

        Example:
            >>> from s2gen.spec import define_system
            >>> s = define_system(name="spin", bodies=1, parameters={}, inputs={"tau": 1.0},
            ...                   diagonal=["2"], potential=0,
            ...                   forces={"F1": "tau*cross(e3, q1)"})
            >>> be, q0 = CBackend(s), np.array([[1.0, 0, 0]])
            >>> st, q, w, e, W, _ = be.integrate_driven("vi", 0.01, 100, q0, 0 * q0,
            ...     be.default_params(), Options(), inputs=np.full((100, 1), 4.0))
            >>> st, round(float(w[-1, 0, 2]), 12), bool(abs(e[-1] - e[0] - W[-1]) < 1e-3)
            (0, 2.0, True)
        """
        n, samples = self.system.n, nsteps // every + 1
        q = np.full((samples, n, 3), np.nan)
        w = np.full((samples, n, 3), np.nan)
        en = np.full(samples, np.nan)
        work = np.full(samples, np.nan)
        u = None if inputs is None else contiguous(np.asarray(inputs, dtype=float))
        if u is not None and u.shape != (nsteps, len(self.system.inputs.names)):
            raise ValueError(
                f"{self.system.name}: inputs of shape {u.shape}, expected "
                f"({nsteps}, {len(self.system.inputs.names)}): one row of inputs per step"
            )
        lib = self.library
        stats = lib.Stats()
        status = self._fn["integrate"](
            contiguous(params),
            ctypes.byref(lib.options(options, every)),
            method(method_name).code,
            t0,
            h,
            nsteps,
            pointer(u),
            None if feedback is None else ctypes.cast(feedback, ctypes.c_void_p),
            None,
            contiguous(q0),
            contiguous(w0),
            q,
            w,
            pointer(en),
            pointer(work),
            self.work,
            ctypes.byref(stats),
        )
        return status, q, w, en, work, lib.stats(stats)

    def step_driven(
        self,
        method_name: str,
        h: float,
        q: np.ndarray,
        w: np.ndarray,
        params: np.ndarray,
        options: Options,
        t: float,
        u: np.ndarray | None,
    ) -> tuple[int, np.ndarray, np.ndarray]:
        """One call of a driven module's step() from (q, w) at t with u held (None: the
        defaults): (status, q+, w+). The options struct is built once per Options object.

        Example:
            >>> from s2gen.spec import define_system
            >>> s = define_system(name="spin", bodies=1, parameters={}, inputs={"tau": 1.0},
            ...                   diagonal=["2"], potential=0,
            ...                   forces={"F1": "tau*cross(e3, q1)"})
            >>> be, q0 = CBackend(s), np.array([[1.0, 0, 0]])
            >>> st, q, w = be.step_driven("vi", 0.1, q0, 0 * q0, be.default_params(),
            ...                           Options(), 0.0, np.array([2.0]))
            >>> st, w.round(12).tolist()  # w+ = h tau / m
            (0, [[0.0, 0.0, 0.1]])
        """
        if getattr(self, "_step_options", (None,))[0] is not options:
            self._step_options = (options, self.library.options(options))
        qn, wn = np.empty_like(q), np.empty_like(w)
        status = self._fn["step"](
            params,
            ctypes.byref(self._step_options[1]),
            method(method_name).code,
            t,
            h,
            pointer(u),
            q,
            w,
            qn,
            wn,
            None,
            self.work,
            None,
        )
        return int(status), qn, wn

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
        progress: Progress | None = None,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray | None, dict[str, Any]]:
        """One call of the emitted integrate(). With `progress`, the call runs in a thread
        (ctypes releases the GIL) while this one reports the fraction done every
        `POLL_SECONDS`, read from the statistics the C updates as it goes (steps taken, or
        the time reached by RK45): the run itself is the same call, bit for bit."""
        n, samples = self.system.n, nsteps // every + 1
        transformed = method(method_name).driver is Driver.TIME_TRANSFORMED
        if transformed:
            self._check_transformed()
        q = np.full((samples, n, 3), np.nan)
        w = np.full((samples, n, 3), np.nan)
        en = np.full(samples, np.nan) if with_energy else None
        lib = self.library
        stats = lib.Stats()
        args = (
            contiguous(params),
            ctypes.byref(lib.options(options, every)),
            method(method_name).code,
            h,
            nsteps,
            contiguous(q0),
            contiguous(w0),
            q,
            w,
            pointer(en),
            self.work,
            ctypes.byref(stats),
        )
        if progress is None or nsteps == 0:
            status = self._fn["integrate"](*args)
        else:
            adaptive = method(method_name).evals == 0
            span = h * nsteps

            def done() -> float:
                if transformed:  # samples stored so far
                    return (stats.fail_step - 1) / (samples - 1)
                return stats.fail_time / span if adaptive else stats.steps / nsteps

            result: list[int] = []
            worker = threading.Thread(target=lambda: result.append(self._fn["integrate"](*args)))
            worker.start()
            while worker.is_alive():
                worker.join(POLL_SECONDS)
                progress(min(1.0, done()))
            status = result[0]
            progress(1.0 if status == 0 else min(1.0, done()))
        return status, q, w, en, lib.stats(stats)

    def _check_transformed(self) -> None:
        """Refuse, in one line, the time-transformed methods for a system whose emitted C has
        no driver for them (checked once per backend)."""
        if not hasattr(self, "_transformed_refusal"):
            self._transformed_refusal = emitted_refusal(self.system)
        if self._transformed_refusal is not None:
            raise ValueError(self._transformed_refusal)
