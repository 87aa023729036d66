"""Lowering: an ordered list of named passes, each a function from `Module` to `Module`.

Input: the unlowered `Module` of a system (`s2gen.equations.assemble`). Output: the lowered
`Module` the printers read. The passes, in order (`PIPELINE`):

- `quadratic`: terms quadratic in the positions summed into one matrix K built once per call,
  their gradient Kq + b (`passes/quadratic.py`);
- `reciprocal`: a body kernel that only divides by the body's mass takes its inverse, computed
  once per call (`passes/reciprocal.py`);
- `factor`: common factors pulled out of sums (`passes/factor.py`);
- `cse`: common subexpressions of each kernel, deterministic temporaries (`passes/cse.py`);
- `hoist`: what depends only on parameters (and a member's data, with its bodies' per-body
  data where the loop gathers them) computed once per call (`passes/hoist.py`);
- `strength`: powers of a base share one division, one square root and a chain of squares
  (`passes/strength.py`);
- `powers`: small integer powers as products (`passes/powers.py`);
- `opcount`: operation counts of each kernel (`passes/opcount.py`);
- `calls`: the call sites the selected parts (`s2gen.parts`) and the term loops declare, each
  argument bound (`s2gen.bindings`) from the kernel's signature (`passes/calls.py`);
- `layout`: loops over all pairs as vectorisable rows on structure-of-arrays copies
  (`passes/layout.py`);
- `workspace`: the caller's workspace laid out per function, for the layouts the selected
  parts read (`passes/workspace.py`).

Each run records the passes and the total operations after each; the emitted files list them.

Example:
    >>> from s2gen.systems import builtin
    >>> [p.name for p in lower_system(builtin("double_pendulum")).passes]
    ['quadratic', 'reciprocal', 'factor', 'cse', 'hoist', 'strength', 'powers', 'opcount', 'calls', 'layout', 'workspace']
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import replace

from s2gen.equations.angles import AngleEquations
from s2gen.equations.assemble import angle_module, sphere_module
from s2gen.equations.assemble import clear_caches as _clear_generic
from s2gen.ir import Kernel, KernelDef, Module, ModuleKind, PassRecord
from s2gen.passes import factor as _factor
from s2gen.passes import opcount as _opcount
from s2gen.passes import powers as _powers
from s2gen.passes import reciprocal as _reciprocal
from s2gen.passes import strength as _strength
from s2gen.passes.calls import calls_pass
from s2gen.passes.cse import cse_pass, lower_kernel
from s2gen.passes.factor import factor_pass
from s2gen.passes.hoist import hoist_pass
from s2gen.passes.layout import layout_pass
from s2gen.passes.opcount import module_ops, opcount_pass
from s2gen.passes.powers import powers_pass
from s2gen.passes.quadratic import quadratic_pass
from s2gen.passes.reciprocal import reciprocal_pass
from s2gen.passes.strength import strength_pass
from s2gen.passes.workspace import workspace_pass
from s2gen.system import System

__all__ = ["PIPELINE", "clear_caches", "lower", "lower_angles", "lower_module", "lower_system"]

Pass = Callable[[Module], Module]

#: Each stage of a derivation, logged at INFO with `since` (seconds since it began): the
#: command line shows them once a derivation has taken `s2gen.cli.PROGRESS_DELAY` seconds.
log = logging.getLogger("s2gen.derive")

#: The lowering passes, in the order they run.
PIPELINE: tuple[tuple[str, Pass], ...] = (
    ("quadratic", quadratic_pass),
    ("reciprocal", reciprocal_pass),
    ("factor", factor_pass),
    ("cse", cse_pass),
    ("hoist", hoist_pass),
    ("strength", strength_pass),
    ("powers", powers_pass),
    ("opcount", opcount_pass),
    ("calls", calls_pass),
    ("layout", layout_pass),
    ("workspace", workspace_pass),
)


def lower_module(
    module: Module, pipeline: tuple[tuple[str, Pass], ...] = PIPELINE, start: float | None = None
) -> Module:
    """Run the passes in order, recording each one and the operations after it; each pass
    done is logged (logger ``s2gen.derive``, INFO) with the seconds since `start`."""
    start = time.perf_counter() if start is None else start
    records = list(module.passes)
    for name, run in pipeline:
        module = run(module)
        ops = module_ops(module)
        records.append(PassRecord(name, ops.total, str(ops)))
        log.info("%s: pass %s done", module.name, name, extra={"since": _since(start)})
    return replace(module, passes=tuple(records))


def _since(start: float) -> float:
    return time.perf_counter() - start


def lower_system(system: System) -> Module:
    """The lowered (S^2)^n module of a system."""
    start = time.perf_counter()
    module = sphere_module(system)
    log.info("%s: equations derived", system.name, extra={"since": _since(start)})
    return lower_module(module, start=start)


def lower_angles(eq: AngleEquations) -> Module:
    """The lowered angle-form module of a system."""
    start = time.perf_counter()
    module = angle_module(eq)
    log.info("%s: angle-form equations derived", module.name, extra={"since": _since(start)})
    return lower_module(module, start=start)


def lower(kdef: KernelDef) -> Kernel:
    """One kernel through the kernel passes (reciprocal, factor, cse, strength, powers,
    opcount), outside any module.

    Example:
        >>> import sympy as sp
        >>> from s2gen.ir import Argument, Output
        >>> x = sp.Symbol("x", real=True)
        >>> k = lower(KernelDef("k", "doc", (Argument("x", (x,), True),),
        ...                     (Output("y", (x**3,), True),)))
        >>> [str(a.expr) for a in k.assignments]
        ['x*x', 'pw0*x']
    """
    module = Module(ModuleKind.SPHERE, "kernel", "", "", 0, (), (), (kdef,), ())
    module = factor_pass(reciprocal_pass(module))
    kernel = opcount_pass(powers_pass(strength_pass(cse_pass(module)))).kernels[0]
    assert isinstance(kernel, Kernel)
    return kernel


def clear_caches() -> None:
    """Forget every kernel derived or lowered in this process."""
    _clear_generic()
    _factor.clear_cache()
    _reciprocal.inverted.cache_clear()
    lower_kernel.cache_clear()
    _strength.clear_cache()
    _powers.clear_cache()
    _opcount.kernel_profile.cache_clear()
    _opcount.definition_profile.cache_clear()
