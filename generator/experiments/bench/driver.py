"""The `s2gen bench` driver: run the requested measurements, write every file; the CLI.

Input: example names, an output folder and switches (Python: `bench`; command line: the
parser of `command.py`, then `run`). Output: a `BenchReport` whose `files` are the CSV tables,
the PNG figures and ``bench.md`` written into the folder; `run` prints them and returns an exit
code.

Example:
    >>> from s2gen.experiments.bench.command import add_parser
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> run(p.parse_args(["bench", "no_such_system"]))  # doctest: +SKIP
    2
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from s2gen import SpecError

from .command import DEFAULT_EXAMPLES, command_line
from .common import Log, _print, example_system
from .encounters import encounter_study
from .envelope import stability
from .figures import write_plots
from .long_study import long_time
from .model import BenchReport, ExampleBench, Reference
from .report import write_markdown
from .sizes import scaling
from .sweeps import has_transformed, work_precision
from .tables import write_tables


def bench(
    examples: Sequence[str] = (),
    out: str | Path = "out/bench",
    quick: bool = False,
    *,
    sweeps: bool = True,
    long: bool = False,
    steps: int | None = None,
    crossover_steps: int | None = None,
    tight: float = 1e-10,
    stability_envelope: bool = False,
    scale: bool = False,
    T: float | None = None,
    pydy_generator: str = "auto",
    command: str | None = None,
    log: Log = _print,
) -> BenchReport:
    """Run the requested measurements and write CSV, Markdown and PNG files into `out`.

    Example:
        >>> report = bench(["double_pendulum"], "out/b", quick=True)  # doctest: +SKIP
        >>> [p.name for p in report.files]  # doctest: +SKIP
        ['bench.csv', 'per_step.csv', 'wp_double_pendulum.png', 'bench.md']
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    names = list(examples) or list(DEFAULT_EXAMPLES)
    cmd = command or "s2gen bench " + " ".join(names) + (" --quick" if quick else "")
    report = BenchReport(folder, cmd)
    for name in names if sweeps or long else ():
        if sweeps:
            ex = work_precision(name, quick, T, pydy_generator, log)
        else:
            system = example_system(name)
            ex = ExampleBench(name, system, Reference(system, 0.0, np.zeros(0), 0, 1, 0, 0))
        if long:
            n = steps or (10**5 if quick else 10**6)
            most = crossover_steps or (10**5 if quick else 10**7)
            ex.long, ex.long_notes, ex.crossovers = long_time(name, n, tight, log, most)
            if has_transformed(ex.system):
                ex.encounters, ex.energy_costs, ex.energy0 = encounter_study(name, n, log)
        ex.name = ex.system.name  # a TOML path names its files and sections by the spec's name
        report.examples.append(ex)
    if stability_envelope:
        report.stability, report.stability_cases = stability(quick, log)
    if scale:
        report.scaling = scaling(quick, log)
    report.files = write_tables(report) + write_plots(report)
    report.files.append(write_markdown(report))
    return report


def run(args: argparse.Namespace) -> int:
    """Carry out `s2gen bench` from parsed arguments; 0 on success, 2 on a bad example name."""
    start = time.perf_counter()
    command = (
        "s2gen " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["bench"] else command_line(args)
    )
    try:
        report = bench(
            args.examples,
            args.out,
            args.quick,
            sweeps=not args.no_sweeps,
            long=args.long,
            steps=args.steps,
            crossover_steps=args.crossover_steps,
            tight=args.tight,
            stability_envelope=args.stability,
            scale=args.scaling,
            T=args.T,
            pydy_generator=args.pydy_generator,
            command=command,
        )
    except SpecError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"done in {time.perf_counter() - start:.1f} s; outputs in {report.out}/:")
    for path in report.files:
        print(f"  {path}")
    return 0
