"""`s2gen bench`: work-precision, long-time, stability and scaling measurements, with reports.

Input: example names (built-in systems; default ``double_pendulum three_bodies dipoles``), an output
folder and switches (`--quick`, `--long`, `--stability`, `--scaling`). Output, in the folder:
``bench.csv`` (one row per run of the work-precision sweeps), ``per_step.csv``, ``bench.md``
(tables and generated findings; every number comes from this run), ``wp_<example>.png``
(work-precision, log-log) and, with the switches, ``long.csv``/``long_<example>.png``,
``stability.csv``/``stability.png``, ``scaling.csv``/``scaling.png``. Progress lines go to
stdout as the work goes on.

Our methods all run on the same emitted C (`runtime.simulate`, backend "c"): the VI family (the
VI "vi", RATTLE "rattle" and their symmetric compositions of orders 4, 6 and 8: "vi4", "vi6",
"vi8", "rattle4", "rattle6", "rattle8"), RK2, RK2 with renormalization, RK4, RK45 under both
error controls and DOP853; on the systems whose emitted C has their driver (closed, with
monitored pair terms or a monitor given as [run] g) also the time-transformed VI
("vi-adaptive", "vi4-adaptive", "vi6-adaptive", "vi8-adaptive") and RATTLE ("rattle4-adaptive",
"rattle8-adaptive": the VI's flow by other operations, so two orders suffice to compare their
cost) over the fictitious step eps. Outside peers (`peers.py`) run in the same process: scipy's
`solve_ivp` (RK45, DOP853) on the emitted NumPy right-hand side, and PyDy (double pendulum).

Definitions (repeated in bench.md):
- state error: the 2-norm of (q, omega)(T) - (q, omega)_ref(T) over all 6n components, the
  reference being our C DOP853 (rtol = atol = 3e-14), cross-checked against vi8 and rattle8 at
  three small steps (the smallest discrepancy is the reference's stated accuracy);
- energy error: max |E - E0| over every step (fixed-step methods) or over T/200-spaced
  samples (adaptive methods and peers; the time-transformed ones: every eps of time), also
  divided by the largest kinetic energy along the reference ("relative"); for our methods
  from a second run that keeps those samples (the adaptive ones take the same steps either
  way);
- cost: best-of-k wall time of the integration call only (our methods: keeping only the final
  state, without energy), and gradient evaluations (for the peers: right-hand-side
  evaluations, each one gradient).

The package, one responsibility per module: `model` (records and method constants), `common`
(shared helpers), `sweeps` and `per_step` (work-precision), `long_runs`, `long_study` and
`crossover` (long time; crossovers with RK at equal error), `encounters` (long horizons with
close encounters: the time-transformed VI against DOP853 at equal energy error), `envelope` (stability), `sizes`
(scaling), `tables` (CSV), `figures` (PNG), `report_example` and `report` (bench.md), `driver`
(`bench`, the CLI). Their public
names (and the private ones the tests use) are re-exported here, so `s2gen.bench` reads as one
module.

Example:
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:  # doctest: +SKIP
    ...     report = bench(["double_pendulum"], d, quick=True)
    ...     sorted(p.name for p in report.files)[:2]
    ['bench.csv', 'bench.md']
"""

from __future__ import annotations

import importlib
from typing import Any

#: Where each public name lives; the submodule is imported on first use, so that importing
#: one part of the package (its command-line parser, say) does not import the rest.
_WHERE = {
    "BenchReport": "model",
    "DEFAULT_EXAMPLES": "command",
    "EVALS_PER_STEP": "model",
    "ExampleBench": "model",
    "FIXED": "model",
    "HORIZONS": "sweeps",
    "LONG_STATES": "long_study",
    "LONG_EPS": "long_study",
    "LONG_TRANSFORMED": "long_study",
    "ENERGY_TARGETS": "encounters",
    "EnergyCost": "encounters",
    "encounter_study": "encounters",
    "energy_costs": "encounters",
    "Log": "common",
    "LongSeries": "model",
    "LongSetup": "model",
    "ORDERS": "model",
    "PER_STEP_METHODS": "per_step",
    "PUBLISHED_N20": "report",
    "REF_RTOL": "model",
    "RK_C": "model",
    "Reference": "model",
    "SAMPLES": "model",
    "ScaleRow": "model",
    "StabRow": "model",
    "StabilityCase": "model",
    "TIE": "report_example",
    "TIME_RATTLE": "model",
    "TIME_TRANSFORMED": "model",
    "VI_FAMILY": "model",
    "WPRow": "model",
    "WP_COLUMNS": "tables",
    "command_line": "command",
    "_lj_encounter": "envelope",
    "_targets": "report_example",
    "_windows": "long_runs",
    "add_parser": "command",
    "bench": "driver",
    "cheapest": "report_example",
    "conserved_components": "long_study",
    "CROSSOVER_TARGETS": "crossover",
    "Crossover": "crossover",
    "crossover_horizon": "crossover",
    "crossovers": "crossover",
    "example_system": "common",
    "findings": "report_example",
    "fitted_orders": "sweeps",
    "has_transformed": "sweeps",
    "kinetic_energy": "common",
    "largest_stable": "envelope",
    "long_setup": "long_study",
    "long_time": "long_study",
    "md_system": "sizes",
    "per_step_times": "per_step",
    "newton_per_substep": "per_step",
    "reference": "sweeps",
    "rotating_triangle": "long_study",
    "run": "driver",
    "scaling": "sizes",
    "stability": "envelope",
    "stability_cases": "envelope",
    "stability_sweep": "envelope",
    "work_precision": "sweeps",
    "write_markdown": "report",
    "write_plots": "figures",
    "write_tables": "tables",
}

__all__ = [
    "CROSSOVER_TARGETS",
    "DEFAULT_EXAMPLES",
    "ENERGY_TARGETS",
    "EVALS_PER_STEP",
    "FIXED",
    "HORIZONS",
    "LONG_EPS",
    "LONG_STATES",
    "LONG_TRANSFORMED",
    "ORDERS",
    "PER_STEP_METHODS",
    "PUBLISHED_N20",
    "REF_RTOL",
    "RK_C",
    "SAMPLES",
    "TIE",
    "TIME_RATTLE",
    "TIME_TRANSFORMED",
    "VI_FAMILY",
    "WP_COLUMNS",
    "BenchReport",
    "Crossover",
    "EnergyCost",
    "ExampleBench",
    "Log",
    "LongSeries",
    "LongSetup",
    "Reference",
    "ScaleRow",
    "StabRow",
    "StabilityCase",
    "WPRow",
    "add_parser",
    "bench",
    "cheapest",
    "conserved_components",
    "crossover_horizon",
    "crossovers",
    "encounter_study",
    "energy_costs",
    "example_system",
    "findings",
    "fitted_orders",
    "has_transformed",
    "kinetic_energy",
    "largest_stable",
    "long_setup",
    "long_time",
    "md_system",
    "newton_per_substep",
    "per_step_times",
    "reference",
    "rotating_triangle",
    "run",
    "scaling",
    "stability",
    "stability_cases",
    "stability_sweep",
    "work_precision",
    "write_markdown",
    "write_plots",
    "write_tables",
]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
