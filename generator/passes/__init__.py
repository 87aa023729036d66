"""Lowering: an ordered list of named passes, each a function from `Module` to `Module`.

Input: the unlowered `Module` of a system (`s2gen.equations.assemble`). Output: the lowered
`Module` the printers read. The passes, in order (`PIPELINE`):

- `cse`: common subexpressions of each kernel, deterministic temporaries (`passes/cse.py`);
- `powers`: small integer powers as products (`passes/powers.py`);
- `opcount`: operation counts of each kernel (`passes/opcount.py`);
- `calls`: every kernel call site resolved from the kernel's signature (`passes/calls.py`);
- `workspace`: the caller's workspace laid out per function (`passes/workspace.py`).

Each run records the passes and the total operations after each; the emitted files list them.

Example:
    >>> from s2gen.systems import builtin
    >>> [p.name for p in lower_system(builtin("double_pendulum")).passes]
    ['cse', 'powers', 'opcount', 'calls', 'workspace']
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from s2gen.equations.angles import AngleEquations
from s2gen.equations.assemble import angle_module, sphere_module
from s2gen.equations.assemble import clear_caches as _clear_generic
from s2gen.ir import Kernel, KernelDef, Module, ModuleKind, PassRecord
from s2gen.passes import opcount as _opcount
from s2gen.passes import powers as _powers
from s2gen.passes.calls import calls_pass
from s2gen.passes.cse import cse_pass, lower_kernel
from s2gen.passes.opcount import module_ops, opcount_pass
from s2gen.passes.powers import powers_pass
from s2gen.passes.workspace import workspace_pass
from s2gen.system import System

__all__ = ["PIPELINE", "clear_caches", "lower", "lower_angles", "lower_module", "lower_system"]

Pass = Callable[[Module], Module]

#: The lowering passes, in the order they run.
PIPELINE: tuple[tuple[str, Pass], ...] = (
    ("cse", cse_pass),
    ("powers", powers_pass),
    ("opcount", opcount_pass),
    ("calls", calls_pass),
    ("workspace", workspace_pass),
)


def lower_module(module: Module, pipeline: tuple[tuple[str, Pass], ...] = PIPELINE) -> Module:
    """Run the passes in order, recording each one and the operations after it."""
    records = list(module.passes)
    for name, run in pipeline:
        module = run(module)
        records.append(PassRecord(name, module_ops(module)))
    return replace(module, passes=tuple(records))


def lower_system(system: System) -> Module:
    """The lowered (S^2)^n module of a system."""
    return lower_module(sphere_module(system))


def lower_angles(eq: AngleEquations) -> Module:
    """The lowered angle-form module of a system."""
    return lower_module(angle_module(eq))


def lower(kdef: KernelDef) -> Kernel:
    """One kernel through the kernel passes (cse, powers, opcount), outside any module.

    Example:
        >>> import sympy as sp
        >>> from s2gen.ir import Argument, Output
        >>> x = sp.Symbol("x", real=True)
        >>> lower(KernelDef("k", "doc", (Argument("x", (x,), True),),
        ...                 (Output("y", (x**3,), True),))).assignments[0].expr
        x*x*x
    """
    module = Module(ModuleKind.SPHERE, "kernel", "", "", 0, (), (), (kdef,), ())
    kernel = opcount_pass(powers_pass(cse_pass(module))).kernels[0]
    assert isinstance(kernel, Kernel)
    return kernel


def clear_caches() -> None:
    """Forget every kernel derived or lowered in this process."""
    _clear_generic()
    lower_kernel.cache_clear()
    _powers.clear_cache()
    _opcount.kernel_ops.cache_clear()
