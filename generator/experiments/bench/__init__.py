"""`s2gen bench`: work-precision, long-time, stability and scaling measurements, with reports.

Input: example names (built-in systems; default ``double_pendulum three_bodies``), an output
folder and switches (`--quick`, `--long`, `--stability`, `--scaling`). Output, in the folder:
``bench.csv`` (one row per run of the work-precision sweeps), ``per_step.csv``, ``bench.md``
(tables and generated findings; every number comes from this run), ``wp_<example>.png``
(work-precision, log-log) and, with the switches, ``long.csv``/``long_<example>.png``,
``stability.csv``/``stability.png``, ``scaling.csv``/``scaling.png``. Progress lines go to
stdout as the work goes on.

Our methods all run on the same emitted C (`runtime.simulate`, backend "c"): the VI ("vi"), its
4th-order Yoshida composition ("vi4"), RATTLE, RK2, RK2 with renormalization, RK4 and RK45
under both error controls. Outside peers (`peers.py`) run in the same process: scipy's
`solve_ivp` (RK45, DOP853) on the emitted NumPy right-hand side, and PyDy (double pendulum).

Definitions (repeated in bench.md):
- state error: the 2-norm of (q, omega)(T) - (q, omega)_ref(T) over all 6n components, the
  reference being our C RK45 (Hairer control, rtol = atol = 1e-13), cross-checked against vi4
  at two small steps (the smaller discrepancy is the reference's stated accuracy);
- energy error: max |E - E0| over every step (fixed-step methods) or over T/200-spaced
  samples (adaptive methods and peers), also divided by the largest kinetic energy along the
  reference ("relative");
- cost: best-of-k wall time of the integration call only, and gradient evaluations (for the
  peers: right-hand-side evaluations, each one gradient).

The package, one responsibility per module: `model` (records and method constants), `common`
(shared helpers), `sweeps` and `per_step` (work-precision), `long_runs` and `long_study`
(long time), `envelope` (stability), `sizes` (scaling), `tables` (CSV), `figures` (PNG),
`report_example` and `report` (bench.md), `driver` (`bench`, the CLI). Their public
names (and the private ones the tests use) are re-exported here, so `s2gen.bench` reads as one
module.

Example:
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:  # doctest: +SKIP
    ...     report = bench(["double_pendulum"], d, quick=True)
    ...     sorted(p.name for p in report.files)[:2]
    ['bench.csv', 'bench.md']
"""

from .common import Log, example_system, kinetic_energy
from .driver import _command as _command
from .driver import add_parser, bench, run
from .envelope import _lj_encounter as _lj_encounter
from .envelope import largest_stable, stability, stability_cases, stability_sweep
from .figures import write_plots
from .long_runs import _windows as _windows
from .long_study import (
    LONG_STATES,
    conserved_components,
    crossover,
    long_setup,
    long_time,
    rotating_triangle,
)
from .model import (
    DEFAULT_EXAMPLES,
    EVALS_PER_STEP,
    FIXED,
    ORDERS,
    REF_RTOL,
    SAMPLES,
    VI_FAMILY,
    BenchReport,
    ExampleBench,
    LongSeries,
    LongSetup,
    Reference,
    ScaleRow,
    StabilityCase,
    StabRow,
    WPRow,
)
from .per_step import PER_STEP_METHODS, per_step_times
from .report import PUBLISHED_N20, write_markdown
from .report_example import TIE, cheapest, findings
from .report_example import _targets as _targets
from .sizes import md_system, scaling
from .sweeps import HORIZONS, fitted_orders, reference, work_precision
from .tables import WP_COLUMNS, write_tables

__all__ = [
    "DEFAULT_EXAMPLES",
    "EVALS_PER_STEP",
    "FIXED",
    "HORIZONS",
    "LONG_STATES",
    "ORDERS",
    "PER_STEP_METHODS",
    "PUBLISHED_N20",
    "REF_RTOL",
    "SAMPLES",
    "TIE",
    "VI_FAMILY",
    "WP_COLUMNS",
    "BenchReport",
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
    "crossover",
    "example_system",
    "findings",
    "fitted_orders",
    "kinetic_energy",
    "largest_stable",
    "long_setup",
    "long_time",
    "md_system",
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
