"""The pipeline opened up, for the experiments: stages, op counts, builds and backends.

The public API (`s2gen`) loads, emits, compiles and integrates a system; this module is the
one internal interface the experiments (`s2gen.experiments`: reproduce, bench,
compare-angles, flags, peers, timings) may use besides it, to look at what the pipeline does
and to time its parts. It is not a stable API: its names follow the pipeline.

- stages: `derived` (the module as derived, before the passes), `lowered` (after them),
  `lowered_angles` (the angle form), `field_kernels` and `lower_kernel` (the S^2 vector field's
  kernel definitions, and one lowered by itself), `c_sources` (a module printed and rendered
  as C files), `solver` (the solver chosen for a system's coupled solves);
- op counts: `kernel_profile` (a lowered `Kernel`), `definition_profile` (a `KernelDef`);
- builds: `FLAG_SETS`, `DEFAULT_FLAGS`, `compiler`, `compile_shared` (a given set of sources
  into a cached library), `header_macro`, `emit` (uncached with ``cache=False``) and
  `clear_caches` (forget every in-process derivation);
- backends: `get_backend` (a system's cached "c", "numpy" or "reference" backend), `c_backend`
  (its C compiled with given gcc flags), `simulate_angles` with `AngleIntegrationError` and
  `PoleError` (the angle form, integrated);
- the method table's records: `method`, `Family`, `BACKENDS`; a spec's `RunSettings`.

Example:
    >>> import s2gen
    >>> module = lowered(s2gen.load("double_pendulum"))
    >>> sorted(c_sources(module))
    ['double_pendulum.c', 'double_pendulum.h']
    >>> kernel_profile(next(k for k in module.kernels if isinstance(k, Kernel))).total > 0
    True
"""

from __future__ import annotations

import hashlib
from typing import Any

from s2gen.build import DEFAULT_FLAGS, FLAG_SETS, compile_shared, compiler, header_macro
from s2gen.emit import clear_caches, emit
from s2gen.ir import Kernel, KernelDef, Module
from s2gen.methods import BACKENDS, Family, method
from s2gen.passes.opcount import definition_profile, kernel_profile
from s2gen.runtime import get_backend as _get_backend
from s2gen.runtime.angles import AngleIntegrationError, PoleError, simulate_angles
from s2gen.system import RunSettings, System

__all__ = [
    "BACKENDS",
    "DEFAULT_FLAGS",
    "FLAG_SETS",
    "AngleIntegrationError",
    "Family",
    "Kernel",
    "KernelDef",
    "Module",
    "PoleError",
    "RunSettings",
    "c_backend",
    "c_sources",
    "clear_caches",
    "compile_shared",
    "compiler",
    "definition_profile",
    "derived",
    "emit",
    "field_kernels",
    "get_backend",
    "header_macro",
    "kernel_profile",
    "lower_kernel",
    "lowered",
    "lowered_angles",
    "method",
    "simulate_angles",
    "solver",
]


def derived(system: System) -> Module:
    """The (S^2)^n module of `system` as derived, before the lowering passes.

    Example:
        >>> import s2gen
        >>> all(isinstance(k, KernelDef) for k in derived(s2gen.load("double_pendulum")).kernels
        ...     if not isinstance(k, Kernel))
        True
    """
    from s2gen.equations.assemble import sphere_module

    return sphere_module(system)


def lowered(system: System) -> Module:
    """The (S^2)^n module of `system` after every lowering pass (what is printed).

    Example:
        >>> import s2gen
        >>> lowered(s2gen.load("double_pendulum")).coupling is not None
        True
    """
    from s2gen.passes import lower_system

    return lower_system(system)


def lowered_angles(system: System, simplify: bool = False) -> Module:
    """The angle form of `system` (polar angles, optionally simplified by SymPy), lowered.

    Example:
        >>> import s2gen
        >>> sorted(c_sources(lowered_angles(s2gen.load("double_pendulum"))))
        ['double_pendulum_angles.c', 'double_pendulum_angles.h']
    """
    from s2gen.equations.angles import derive_angles
    from s2gen.passes import lower_angles

    return lower_angles(derive_angles(system, simplify=simplify))


def field_kernels(system: System) -> list[KernelDef]:
    """The kernel definitions of the S^2 vector field of `system` (continuous, system and
    term kernels), derived here and not lowered.

    Example:
        >>> import s2gen
        >>> len(field_kernels(s2gen.load("double_pendulum"))) > 0
        True
    """
    from s2gen.equations.continuous import continuous_kernels
    from s2gen.equations.structure import coupling_pairs, system_kernels, term_kernels

    defs = continuous_kernels(bool(coupling_pairs(system))) + system_kernels(system)
    return defs + [k for i, t in enumerate(system.terms) for k in term_kernels(system, i, t)]


def lower_kernel(kernel: KernelDef) -> Kernel:
    """One kernel definition through the lowering passes.

    Example:
        >>> import s2gen
        >>> k = lower_kernel(field_kernels(s2gen.load("double_pendulum"))[0])
        >>> k.ops_after <= k.ops_before
        True
    """
    from s2gen.passes import lower

    return lower(kernel)


def c_sources(module: Module) -> dict[str, str]:
    """The C files of a lowered module, printed and rendered ({name: text}).

    Example:
        >>> import s2gen
        >>> system = s2gen.load("double_pendulum")
        >>> c_sources(lowered(system)) == s2gen.generate(system, "c")
        True
    """
    from s2gen.printing import print_module
    from s2gen.render import render

    return render(print_module(module), "c")


def solver(system: System) -> str:
    """The solver of a system's coupled solves: "diagonal", "dense", "banded" or "max-index".

    Example:
        >>> import s2gen
        >>> solver(s2gen.load("double_pendulum"))
        'dense'
    """
    from s2gen.equations.structure import choose_solver

    return str(choose_solver(system).value)


def get_backend(system: System, name: str) -> Any:
    """The cached backend of `system`: "c" (the compiled library), "numpy" (the emitted
    module, as `.module`) or "reference".

    Example:
        >>> import s2gen
        >>> get_backend(s2gen.load("double_pendulum"), "numpy").name
        'numpy'
    """
    return _get_backend(system, name)


def c_backend(system: System, flags: tuple[str, ...]) -> Any:
    """The emitted C of `system` compiled with exactly the gcc `flags` (a cached build of its
    own) and loaded, as the "c" backend is.

    Example:
        >>> import s2gen
        >>> pendulum = s2gen.load("double_pendulum")
        >>> fast = c_backend(pendulum, (*DEFAULT_FLAGS, "-O3"))
        >>> fast.build.path != c_backend(pendulum, DEFAULT_FLAGS).build.path
        True
    """
    from s2gen.runtime.c import CBackend

    label = "_" + hashlib.sha256("\0".join(flags).encode()).hexdigest()[:12]
    FLAG_SETS[label] = tuple(flags)
    try:
        return CBackend(system, opt=label)
    finally:
        del FLAG_SETS[label]
