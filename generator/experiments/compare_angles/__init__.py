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
    >>> from s2gen.systems import builtin
    >>> c = compare(builtin("double_pendulum"), Settings.quick(), "/tmp/ca")  # doctest: +SKIP
    >>> c.accuracy[1].status  # doctest: +SKIP
    'PoleError'
"""

from .chains import chain_system, scaling
from .cost import RhsTimer, costs, gcc_seconds, generic_angles, generic_state
from .derive import derive_with_budget
from .driver import add_parser, compare, run, settings_from_args, write_all
from .figures import accuracy_figure, pole_error_figure, pole_steps_figure, scaling_figure
from .model import FORMS, ZOOM, Comparison, Cost, PoleCase, Run, Settings
from .pole import _passage as _passage
from .pole import pole_body, pole_study, through_tilt, tilted_state
from .report import markdown, to_json, write_json
from .trajectories import accuracy, reference

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
