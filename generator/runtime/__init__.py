"""Run a system with one backend: compiled models, `simulate`, `Trajectory`.

Input: a `System`, a method (see `s2gen.methods`), a backend ("c": emitted C compiled and
loaded with ctypes; "numpy": the emitted NumPy module; "reference": the independent
`s2gen.reference`), step size, horizon and options. Output: a `Trajectory` (t, q, omega,
energy, angular momentum, statistics, wall time, the spec and parameter values that rebuild
the run, and its energy check). A finished run whose relative energy error passes
`Options.energy_warn` warns with an `EnergyDriftWarning` (`s2gen.runtime.diagnostics`). A failure raises `IntegrationError`, which names the step and
why and keeps the trajectory computed so far (`.partial`); a stored sample whose energy is not
finite while its state is counts as such a failure (status NONFINITE). A method a backend does
not have is refused before anything runs, and so is a request the machine cannot serve
(`check_run`: h and T finite and positive, T a whole number of steps, at most `MAX_SAMPLES`
samples, trajectory arrays within `MAX_MEMORY_FRACTION` of the physical memory, tolerances
finite and positive with rtol at least `RTOL_FLOOR` and atol at least `ATOL_FLOOR`), and
parameters of the wrong count or not finite, and an initial state where the potential's
gradient or (when the energy is kept) the energy is not finite: a ValueError of one line
saying the limit.

Example:
    >>> from s2gen.systems import builtin
    >>> tr = simulate(builtin("double_pendulum"), method="vi", backend="c", h=0.01, T=0.1)
    >>> tr.q.shape
    (11, 2, 3)
"""

from __future__ import annotations

import functools
import math
import numbers
import os
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from s2gen.methods import BACKENDS, CONTROLS, NAMES, Status, check_method
from s2gen.methods import method as method_record
from s2gen.runtime.diagnostics import EnergyDriftWarning, checked, energy_scale, first_nonfinite
from s2gen.runtime.inputs import initial_state, parameter_vector
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import IntegrationError, Trajectory
from s2gen.system import System

__all__ = [
    "ATOL_FLOOR",
    "BACKENDS",
    "CONTROLS",
    "MAX_MEMORY_FRACTION",
    "MAX_SAMPLES",
    "MAX_STEPS",
    "METHODS",
    "RTOL_FLOOR",
    "Backend",
    "EnergyDriftWarning",
    "IntegrationError",
    "Options",
    "Trajectory",
    "check_run",
    "failure",
    "get_backend",
    "nonfinite_energy",
    "run",
    "simulate",
]

#: Method names (the table is `s2gen.methods.METHODS`).
METHODS = NAMES

#: Most samples (t = 0 included) one run may hold: 2^31, the count a C int can index.
MAX_SAMPLES = 2**31
#: Most steps of one run (the emitted C counts them in a long).
MAX_STEPS = 2.0**62
#: The trajectory arrays (t, q, omega, energy) may take at most this fraction of the
#: machine's physical memory.
MAX_MEMORY_FRACTION = 0.5
#: Smallest relative tolerance: 100 machine epsilons (MATLAB ode45's floor); below it the
#: error control asks for more than double precision can give, and with ode45's weights
#: max(|y|, atol/rtol) a tiny rtol silently switches the control off.
RTOL_FLOOR = 100 * float(np.finfo(float).eps)
#: Smallest absolute tolerance: below it, round-off in components that should stay 0 drives
#: the RK45 step size toward 0 without reaching the minimum step that would stop the run (four
#: pendula at rtol = RTOL_FLOOR over T = 1: 4,600 steps at atol = 1e-20, 2.3 million at 1e-40;
#: at 1e-300 it never finished).
ATOL_FLOOR = 1e-20


class Backend(Protocol):
    """What every backend offers (C, NumPy, reference)."""

    name: str
    system: System

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
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray | None, dict[str, int]]: ...

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float: ...

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray: ...

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray: ...


@functools.lru_cache(maxsize=16)
def _backend_cached(system: System, name: str) -> Backend:
    if name == "c":
        from s2gen.runtime.c import CBackend

        return CBackend(system)
    if name == "numpy":
        from s2gen.runtime.numpy_module import NumpyBackend

        return NumpyBackend(system)
    from s2gen.runtime.reference_backend import ReferenceBackend

    return ReferenceBackend(system)


def get_backend(system: System, name: str) -> Any:
    """The (cached) backend object of a system: "c", "numpy" or "reference"."""
    if name not in BACKENDS:
        raise ValueError(f"unknown backend {name!r}; choose one of {', '.join(BACKENDS)}")
    return _backend_cached(system, name)


def simulate(
    system: System,
    method: str = "vi",
    backend: str = "c",
    h: float | None = None,
    T: float | None = None,
    options: Options | None = None,
    params: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    q0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
    every: int = 1,
    energy: bool = True,
    progress: Callable[[float], None] | None = None,
    t0: float = 0.0,
    inputs: Any = None,
) -> Trajectory:
    """Integrate a system from its (or the given) initial state at time t0 over T with step
    h, keeping every `every`-th sample (T/h must be a multiple of it) and, with `energy`, its
    energy and angular momentum (and the energy check, `s2gen.runtime.diagnostics`);
    `params` are values by name ({"g": 1.62}, the others the spec's) or all of them in
    declared order; `progress(fraction)` is called as the run goes (see `run`). A driven
    system (forces, inputs or time t; C backend, the VI family and the explicit
    Runge-Kutta methods) takes `inputs`: None (the defaults), an array of shape (steps,
    n_inputs), row k held over step k, or state feedback ``u(t, q, w)`` called once per step
    (`s2gen.runtime.driven`); its trajectory keeps the work done (`Trajectory.work`) and the
    inputs held, and its energy check is on the balance E - E0 - W.

    Example:
        >>> from s2gen.systems import builtin
        >>> tr = simulate(builtin("double_pendulum"), h=0.01, T=0.1, params={"g": 1.62})
        >>> tr.params["g"], tr.momentum.shape
        (1.62, (11, 3))
    """
    check_method(method, backend)
    return run(
        get_backend(system, backend),
        method,
        h,
        T,
        options,
        params,
        q0,
        omega0,
        every,
        energy,
        progress,
        t0,
        inputs,
    )


def run(
    be: Backend,
    method: str = "vi",
    h: float | None = None,
    T: float | None = None,
    options: Options | None = None,
    params: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    q0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
    every: int = 1,
    energy: bool = True,
    progress: Callable[[float], None] | None = None,
    t0: float = 0.0,
    inputs: Any = None,
) -> Trajectory:
    """`simulate` on a given backend object (a `Model` brings its own). `progress(fraction)`
    is called a few times a second while the emitted C runs (the run is one call either way,
    so the result does not depend on it), and once at the end on the other backends. `t0`
    is the start time; `inputs` a driven system's inputs (`s2gen.runtime.driven`)."""
    system, backend = be.system, be.name
    check_method(method, backend)
    if not isinstance(t0, (int, float, np.floating)) or not math.isfinite(t0):
        raise ValueError(f"t0 = {t0!r}: must be a finite number")
    if system.driven:
        from s2gen.runtime.driven import check_driven_method

        check_driven_method(system, method, backend)
    elif inputs is not None:
        raise ValueError(f"{system.origin}: inputs given, but the system has no [inputs]")
    h = h if h is not None else system.run.h
    T = T if T is not None else system.run.T
    if h is None or T is None:
        raise ValueError(f"{system.origin}: no step size h or final time T given (spec [run])")
    opts = options or Options()
    nsteps = check_run(system, method, h, T, opts, every)
    q0, omega0 = initial_state(system, q0, omega0, opts.unit_tol)
    p = parameter_vector(system, params)
    scale = energy_scale(be, q0, omega0, p, energy)  # V not finite at q0: refused here
    start = time.perf_counter()
    held: np.ndarray | None = None
    work: np.ndarray | None = None
    feedback_error: str | None = None
    if system.driven:
        status, q, w, en, work, held, feedback_error, stats = _driven_call(
            be, method, h, nsteps, q0, omega0, p, opts, t0, inputs, every
        )
        if not energy:
            en = None
        if progress is not None:
            progress(1.0)
    elif progress is not None and backend == "c":
        status, q, w, en, stats = be.integrate(  # type: ignore[call-arg]
            method, h, nsteps, q0, omega0, p, opts, every, energy, progress=progress
        )
    else:
        status, q, w, en, stats = be.integrate(
            method, h, nsteps, q0, omega0, p, opts, every, energy
        )
        if progress is not None:
            progress(1.0)
    wall = time.perf_counter() - start
    t = t0 + h * every * np.arange(nsteps // every + 1)
    meta = _metadata(system, method, opts, p)
    if system.driven:
        meta.update(work=work, inputs=held)
    k = int(stats.get("fail_step", 0)) if status != 0 else len(t)
    why = Status(status).message if status in Status._value2member_map_ else str(status)
    if feedback_error is not None or (status == int(Status.NONFINITE) and held is not None):
        why = feedback_error or f"an input is not finite ({why})"
    bad_energy = first_nonfinite(en, k)
    if bad_energy is not None:  # the state is finite there (else the backend had stopped)
        k, status = bad_energy, int(Status.NONFINITE)
        why = nonfinite_energy(t, k)
        stats = {**stats, "fail_step": k}
    if status != 0:
        kept = None if en is None else en[:k]
        if work is not None:
            meta.update(work=work[:k])
        partial = Trajectory(t[:k], q[:k], w[:k], kept, method, backend, h, stats, wall, **meta)
        partial = checked(partial, system, scale, opts.energy_warn, warn=False)
        raise IntegrationError(failure(method, backend, t, k, why), status, k, partial)
    tr = Trajectory(t, q, w, en, method, backend, h, stats, wall, **meta)
    return checked(tr, system, scale, opts.energy_warn)


def nonfinite_energy(t: np.ndarray, k: int) -> str:
    """Why a run stops at sample k whose state is finite and whose energy is not."""
    return (
        f"the energy is not finite at t = {t[k]:.6g} while the state is (the potential or "
        "the kinetic energy is undefined there or beyond the range of a double: check V "
        "and the parameters)"
    )


def failure(method: str, backend: str, t: np.ndarray, k: int, why: str) -> str:
    """The message of a run that failed after its k valid samples (times t).

    Example:
        >>> failure("vi", "c", np.array([0.0, 0.5]), 2, "a reason")
        'vi (c) failed after t = 0.5: a reason; the 2 valid samples are kept'
    """
    last = f"after t = {t[k - 1]:.6g}" if k else "at the initial state"
    return f"{method} ({backend}) failed {last}: {why}; the {k} valid samples are kept"


def _driven_call(
    be: Backend,
    method: str,
    h: float,
    nsteps: int,
    q0: np.ndarray,
    omega0: np.ndarray,
    p: np.ndarray,
    opts: Options,
    t0: float,
    inputs: Any,
    every: int,
) -> tuple[Any, ...]:
    """A driven run on the C or NumPy backend: (status, q, w, energy, work, inputs held, the
    input function's error or None, stats)."""
    from s2gen.runtime.driven import Feedback, input_rows

    system = be.system
    rows = input_rows(system, inputs, nsteps)
    fb = Feedback(inputs, system.n, len(system.inputs.names)) if callable(inputs) else None
    feedback = fb and (fb.function if be.name == "c" else fb.held)
    status, q, w, en, work, stats = be.integrate_driven(  # type: ignore[attr-defined]
        method, h, nsteps, q0, omega0, p, opts, t0, rows, every, feedback
    )
    held = rows if fb is None else fb.rows
    if held is None and system.inputs.names:
        held = np.tile(np.array(system.inputs.values, dtype=float), (nsteps, 1))
    return status, q, w, en, work, held, fb and fb.error, stats


def _metadata(system: System, method: str, opts: Options, p: np.ndarray) -> dict[str, Any]:
    """The Trajectory metadata of a run: system, spec hash, the spec text or built-in that
    rebuilds it, the parameter values and, when adaptive, the tolerances."""
    meta: dict[str, Any] = {
        "system": system.name,
        "spec_hash": system.spec_hash(),
        "spec": system.source,
        "spec_folder": system.source_folder,
        "params": dict(zip(system.parameter_names, p.tolist())),
    }
    if method_record(method).adaptive:
        meta.update(rtol=opts.rtol, atol=opts.atol, control=opts.control)
    return meta


def _physical_memory() -> int | None:
    """Bytes of physical memory, or None where the platform does not say."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return None


def _bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if n < 1024 or unit == "EiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} EiB"  # pragma: no cover


def check_run(
    system: System,
    method: str,
    h: float,
    T: float,
    options: Options | None = None,
    every: int = 1,
) -> int:
    """The number of steps of a run, after checking that it can be served (ValueError else).

    h and T must be finite and positive with T a whole number of steps, and `every` (the
    output stride) a positive divisor of the steps; the run may keep at most `MAX_SAMPLES`
    samples and its trajectory arrays at most `MAX_MEMORY_FRACTION` of the physical memory;
    rtol must lie in [`RTOL_FLOOR`, 1] and atol be finite and at least `ATOL_FLOOR`.

    Example:
        >>> from s2gen.systems import builtin
        >>> check_run(builtin("double_pendulum"), "vi", 0.01, 1.0)
        100
        >>> check_run(builtin("double_pendulum"), "vi", 0.01, 1e12)
        Traceback (most recent call last):
        ...
        ValueError: T / h = 1e+12 / 0.01 = 1e+14 steps kept every 1: more than one run may hold (2147483648 samples, 4.61169e+18 steps); raise h, every or shorten T
    """
    for key, value in (("step size h", h), ("final time T", T)):
        if not isinstance(value, (int, float, np.floating)) or not math.isfinite(value):
            raise ValueError(f"{key} = {value!r}: must be a finite number")
        if value <= 0:
            raise ValueError(f"{key} = {value:g}: must be positive")
    if not (isinstance(every, (int, np.integer)) and not isinstance(every, bool) and every >= 1):
        raise ValueError(f"every = {every!r}: must be a positive whole number of steps")
    ratio = T / h
    if not math.isfinite(ratio) or ratio / every + 1 > MAX_SAMPLES or ratio > MAX_STEPS:
        raise ValueError(
            f"T / h = {T:g} / {h:g} = {ratio:g} steps kept every {every}: more than one run "
            f"may hold ({MAX_SAMPLES} samples, {MAX_STEPS:g} steps); raise h, every or shorten T"
        )
    nsteps = round(ratio)
    if nsteps < 1:
        raise ValueError(f"final time T = {T:g} is shorter than one step h = {h:g}")
    if abs(nsteps * h - T) > 1e-9 * T:
        raise ValueError(f"T={T} is not a whole number of steps h={h}")
    if nsteps % every:
        raise ValueError(f"every={every!r} must be a positive divisor of the {nsteps} steps")
    per_sample = 8 * (2 * 3 * system.n + 2)  # q, omega, energy, t
    need, memory = (nsteps // every + 1) * per_sample, _physical_memory()
    if memory is not None and need > MAX_MEMORY_FRACTION * memory:
        raise ValueError(
            f"T / h = {T:g} / {h:g}: the trajectory arrays would take {_bytes(need)}, more "
            f"than {MAX_MEMORY_FRACTION:g} of this machine's {_bytes(memory)} of memory; raise "
            "h or shorten T"
        )
    _check_options(options or Options())
    return nsteps


def _check_options(opts: Options) -> None:
    """Tolerances and Newton settings finite and in range (ValueError naming the option)."""
    if not isinstance(opts, Options):
        raise ValueError(  # noqa: TRY004 (bad input is a ValueError: the CLI reports those)
            f"options must be an s2gen.Options, got {type(opts).__name__}"
        )
    for key in ("rtol", "atol", "newton_tol", "hmax", "unit_tol", "energy_warn"):
        value = getattr(opts, key)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ValueError(f"{key} = {value!r}: must be a number")  # noqa: TRY004
    for key in ("rtol", "atol", "newton_tol"):
        value = getattr(opts, key)
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"{key} = {value}: must be a finite positive number")
    if opts.rtol < RTOL_FLOOR or opts.rtol > 1:
        raise ValueError(
            f"rtol = {opts.rtol:g}: must lie between {RTOL_FLOOR:.3g} (100 machine epsilons, "
            "MATLAB ode45's floor) and 1"
        )
    if opts.atol < ATOL_FLOOR:
        raise ValueError(
            f"atol = {opts.atol:g}: must be at least {ATOL_FLOOR:g} (below it round-off drives "
            "the RK45 step size toward 0)"
        )
    if not math.isfinite(opts.hmax) or opts.hmax < 0:
        raise ValueError(f"hmax = {opts.hmax}: must be finite and >= 0 (0 means T/10)")
    maxiter = opts.newton_maxiter
    if isinstance(maxiter, bool) or not isinstance(maxiter, numbers.Integral) or maxiter < 1:
        raise ValueError(f"newton_maxiter = {maxiter!r}: must be a whole number, at least 1")
    budget = opts.max_steps
    if isinstance(budget, bool) or not isinstance(budget, numbers.Integral):
        raise ValueError(  # noqa: TRY004 (bad input is a ValueError: the CLI reports those)
            f"max_steps = {budget!r}: must be a whole number >= 0 (0: no limit)"
        )
    if not 0 <= int(budget) <= 2**31 - 1:
        raise ValueError(f"max_steps = {budget}: must lie between 0 (no limit) and 2147483647")
    if math.isnan(opts.energy_warn) or opts.energy_warn < 0:
        raise ValueError(f"energy_warn = {opts.energy_warn}: must be >= 0 (0 or inf: no check)")
    if opts.control not in CONTROLS:
        raise ValueError(f"control = {opts.control!r}: choose one of {', '.join(CONTROLS)}")
