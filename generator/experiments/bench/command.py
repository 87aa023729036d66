"""The `s2gen bench` command line: its parser and its canonical form (imports nothing heavy).

Input: an argparse subparsers object, or parsed arguments. Output: the registered `bench`
subcommand; the command line equivalent to parsed arguments (quoted in reports).

Example:
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> command_line(p.parse_args(["bench", "--quick"]))
    's2gen bench --out out/bench --quick'
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["DEFAULT_EXAMPLES", "add_parser", "command_line"]

#: The systems `s2gen bench` measures when none are named.
DEFAULT_EXAMPLES = ("double_pendulum", "three_bodies")


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
        help=f"built-in systems or TOML spec files (default: {' '.join(DEFAULT_EXAMPLES)})",
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


def command_line(args: argparse.Namespace) -> str:
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
