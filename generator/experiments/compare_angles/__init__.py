"""The (S^2)^n form against the classical spherical-angle form: numbers and pictures.

Input: a `System` (SPEC) and `Settings`. Output: a `Comparison` (every number), written as
``compare_angles.md`` (Markdown tables), ``compare_angles.json`` and PNG figures to a folder.

What is measured, for both forms generated from the same (M, V):
- cost: derivation + cse time (each derivation in a fresh subprocess under a time budget, so a
  blow-up is reported as "> budget" instead of hanging), operations after cse (the lowered
  kernels' op counts: the right-hand-side kernels once, and as evaluated per call), emitted C
  size, gcc -O2 time, time per right-hand-side evaluation (emitted C, best of k);
- accuracy: RK45 at the same tolerances and RK4 at the same h, against a converged S^2 reference
  (S^2 RK45 at rtol 1e-12); every metric on (q, omega) samples, the angle form's mapped back, the
  energy by the S^2 module's energy function (`metrics.summary`);
- near a pole: the body nearest a pole at t = 0 is turned onto it, moved back along its motion
  by `alpha` and tilted by beta (`tilted_state`); the tilt beta* whose trajectory passes
  through the pole is found by bisection (`through_tilt`), and beta* + delta for delta in
  `tilts` pass about delta from it: accuracy, accepted/rejected RK45 steps over time, failures;
- scaling: chains of n = 1..`chain_max` spherical pendula (`chain_system`).

The S^2 module reports only total step counts, so its steps over time are measured by runs to
successive horizons with a fixed hmax (the same step sequence up to the last, clipped step);
the angle module writes its cumulative counts at every sample.

The package, one responsibility per module: `model` (settings and records), `derive` and
`cost` (cost of each form), `trajectories` (accuracy), `pole` (near a pole), `chains`
(scaling), `report` (Markdown, JSON), `figures` (PNG), `driver` (`compare`, the CLI).
Their public names (and the private ones the tests use) are re-exported here, so
`s2gen.compare_angles` reads as one module.

Example:
    >>> import s2gen
    >>> c = compare(s2gen.load("double_pendulum"), Settings.quick(), "/tmp/ca")  # doctest: +SKIP
    >>> c.accuracy[1].status  # doctest: +SKIP
    'PoleError'
"""

from __future__ import annotations

import importlib
from typing import Any

#: Where each public name lives; the submodule is imported on first use, so that importing
#: one part of the package (its command-line parser, say) does not import the rest.
_WHERE = {
    "Comparison": "model",
    "Cost": "model",
    "FORMS": "settings",
    "PoleCase": "model",
    "RhsTimer": "cost",
    "Run": "model",
    "Settings": "settings",
    "ZOOM": "settings",
    "_passage": "pole",
    "accuracy": "trajectories",
    "accuracy_figure": "figures",
    "add_parser": "command",
    "chain_system": "chains",
    "compare": "driver",
    "costs": "cost",
    "derive_with_budget": "derive",
    "gcc_seconds": "cost",
    "generic_angles": "cost",
    "generic_state": "cost",
    "markdown": "report",
    "pole_body": "pole",
    "pole_error_figure": "figures",
    "pole_steps_figure": "figures",
    "pole_study": "pole",
    "reference": "trajectories",
    "run": "driver",
    "scaling": "chains",
    "scaling_figure": "figures",
    "settings_from_args": "command",
    "through_tilt": "pole",
    "tilted_state": "pole",
    "to_json": "report",
    "write_all": "driver",
    "write_json": "report",
}

__all__ = [
    "FORMS",
    "ZOOM",
    "Comparison",
    "Cost",
    "PoleCase",
    "RhsTimer",
    "Run",
    "Settings",
    "accuracy",
    "accuracy_figure",
    "add_parser",
    "chain_system",
    "compare",
    "costs",
    "derive_with_budget",
    "gcc_seconds",
    "generic_angles",
    "generic_state",
    "markdown",
    "pole_body",
    "pole_error_figure",
    "pole_steps_figure",
    "pole_study",
    "reference",
    "run",
    "scaling",
    "scaling_figure",
    "settings_from_args",
    "through_tilt",
    "tilted_state",
    "to_json",
    "write_all",
    "write_json",
]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
