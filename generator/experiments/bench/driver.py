"""The `s2gen bench` driver: run the requested measurements, write every file; the CLI.

Input: example names, an output folder and switches (Python: `bench`; command line:
`add_parser` then `run`). Output: a `BenchReport` whose `files` are the CSV tables, the PNG
figures and ``bench.md`` written into the folder; `run` prints them and returns an exit code.

Example:
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> _command(p.parse_args(["bench", "three_bodies", "--long", "--steps", "1000"]))
    's2gen bench three_bodies --out out/bench --long --steps 1000'
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from s2gen.system import SpecError

from .common import Log, _print, example_system
from .envelope import stability
from .figures import write_plots
from .long_study import long_time
from .model import DEFAULT_EXAMPLES, BenchReport, ExampleBench, Reference
from .report import write_markdown
from .sizes import scaling
from .sweeps import work_precision
from .tables import write_tables


def bench(
    examples: Sequence[str] = (),
    out: str | Path = "out/bench",
    quick: bool = False,
    *,
    sweeps: bool = True,
    long: bool = False,
    steps: int | None = None,
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
            ex.long, ex.long_notes = long_time(name, n, tight, log)
        report.examples.append(ex)
    if stability_envelope:
        report.stability, report.stability_cases = stability(quick, log)
    if scale:
        report.scaling = scaling(quick, log)
    report.files = write_tables(report) + write_plots(report)
    report.files.append(write_markdown(report))
    return report


def add_parser(subparsers: Any) -> None:
    """Register `s2gen bench` on an argparse subparsers object (the CLI calls `run`).

    Example:
        >>> p = argparse.ArgumentParser()
        >>> add_parser(p.add_subparsers(dest="command"))
        >>> p.parse_args(["bench", "--quick"]).quick
        True
    """
    b = subparsers.add_parser(
        "bench",
        help="work-precision, long-time, stability and scaling benchmarks against peers",
        description="Measure every integrator (emitted C) and the outside peers (scipy, PyDy) "
        "over sweeps of h or tolerance; write bench.csv, bench.md and PNG plots to --out.",
    )
    b.add_argument(
        "examples",
        nargs="*",
        metavar="EXAMPLE",
        help=f"built-in systems (default: {' '.join(DEFAULT_EXAMPLES)})",
    )
    b.add_argument("--out", default="out/bench", help="output folder (default out/bench)")
    b.add_argument("--quick", action="store_true", help="short horizons and sweeps (~a minute)")
    b.add_argument("--T", type=float, help="horizon of the work-precision sweeps")
    b.add_argument("--no-sweeps", action="store_true", help="skip the work-precision sweeps")
    b.add_argument("--long", action="store_true", help="long-time runs (energy drift, crossover)")
    b.add_argument("--steps", type=int, help="steps of the long runs (default 1e6; quick 1e5)")
    b.add_argument(
        "--tight",
        type=float,
        default=1e-10,
        help="tolerance of the long RK45 and DOP853 runs (default 1e-10)",
    )
    b.add_argument("--stability", action="store_true", help="stability envelope on hard cases")
    b.add_argument("--scaling", action="store_true", help="generation and step time against n")
    b.add_argument(
        "--pydy-generator",
        choices=("auto", "cython", "lambdify"),
        default="auto",
        help="PyDy code generator (auto: cython if it builds; quick: lambdify)",
    )


def _command(args: argparse.Namespace) -> str:
    """The `s2gen bench` command line equivalent to parsed arguments."""
    parts = ["s2gen", "bench", *args.examples, "--out", str(args.out)]
    flags = ("quick", "no_sweeps", "long", "stability", "scaling")
    parts += [f"--{f.replace('_', '-')}" for f in flags if getattr(args, f)]
    for key in ("T", "steps"):
        if getattr(args, key) is not None:
            parts += [f"--{key}", str(getattr(args, key))]
    if args.tight != 1e-10:
        parts += ["--tight", str(args.tight)]
    if args.pydy_generator != "auto":
        parts += ["--pydy-generator", args.pydy_generator]
    return " ".join(parts)


def run(args: argparse.Namespace) -> int:
    """Carry out `s2gen bench` from parsed arguments; 0 on success, 2 on a bad example name."""
    start = time.perf_counter()
    command = "s2gen " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["bench"] else _command(args)
    try:
        report = bench(
            args.examples,
            args.out,
            args.quick,
            sweeps=not args.no_sweeps,
            long=args.long,
            steps=args.steps,
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
