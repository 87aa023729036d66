"""Batches of driven systems: integrate_batch() with a start time, inputs and the work done.

A sphere module of a driven system (forces, inputs or time t) emitted from
`System.with_batch` carries ``NAME_integrate_batch`` with the driven integrate()'s arguments
for K members (`s2gen.interface_batch.INTEGRATE_BATCH_DRIVEN`): each member its own
parameters, initial state and input schedule, one t0, h and nsteps for all. The members run
one after the other, each on its own context (its parameters, time and held inputs) in one
member's workspace, through the driven step of integrate() (`c/_driven.jinja`), reading its
inputs from and writing its samples, energy and work to the caller's member-innermost arrays:
a member's results equal integrate()'s bit for bit, whatever the other members do. No SIMD
lanes: the driven steps (forces, the power at each stage, RK45's and DOP853's own step
sizes) are not laid out over lanes.

The methods: every driven method of integrate() (`s2gen.methods.driven_methods`). State
feedback (integrate()'s callback) is not taken: a batch's inputs are schedules only.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> m = lower_system(builtin("forced_double_pendulum").with_batch())
    >>> DRIVEN_BATCH_PART in m.parts, "batch" in m.parts
    (True, False)
    >>> driven_batch_work(m) == m.work_size + len(m.parameter_names)
    True
"""

from __future__ import annotations

from s2gen.ir import Module
from s2gen.parts.records import Part

__all__ = ["DRIVEN_BATCH_PART", "PART", "driven_batch_work"]

#: The part's name (`Module.parts`) and its partial, c/_batch_driven.jinja (C only).
DRIVEN_BATCH_PART = "batch_driven"

PART = Part(DRIVEN_BATCH_PART, buffers=(("driven", ("qk", "wk", "q1", "w1", "ub")),))


def driven_batch_work(module: Module) -> int:
    """Doubles of a driven integrate_batch()'s workspace, whatever K: one member's workspace
    (WORK_SIZE) and its parameters (NPARAMS)."""
    return module.work_size + max(1, len(module.parameter_names))
