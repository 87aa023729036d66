"""The `s2gen reproduce` command line: its parser and its run (imports nothing heavy until run).

Input: an argparse subparsers object, or parsed arguments. Output: the registered `reproduce`
subcommand; `run` carries it out and returns the exit code (1 when any run or figure failed).

Example:
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> p.parse_args(["reproduce", "--quick"]).quick
    True
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from s2gen.inspect import BACKENDS

from .paper import EXAMPLES

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register `s2gen reproduce` on an argparse subparsers object."""
    rp = sub.add_parser(
        "reproduce",
        help="rerun the paper's numerical examples; write results.csv, results.md, figures",
        description="Rerun the paper's examples with the emitted code, compare with the "
        "printed values, and write results.csv, results.md and PNG figures to --out.",
    )
    rp.add_argument(
        "examples",
        nargs="*",
        metavar="EXAMPLE",
        help=f"examples to run (default all): {', '.join(EXAMPLES)}",
    )
    rp.add_argument("--out", default="out/reproduce", help="folder (default out/reproduce)")
    rp.add_argument("--quick", action="store_true", help="shortened runs (about 15 s)")
    rp.add_argument("--backend", choices=BACKENDS, default="c", help="default c")
    rp.add_argument(
        "--bands",
        type=int,
        default=0,
        metavar="N",
        help="also run the rod's two runs as ensembles of N members perturbed by 1e-13 on a "
        "local Dask cluster and state their chaos bands (N = 64: about 30 s on 2 cores)",
    )


def run(args: argparse.Namespace) -> int:
    """Carry out `s2gen reproduce`; print the files written and any error line."""
    from .runner import reproduce

    start = time.perf_counter()
    report = reproduce(
        args.examples, args.out, quick=args.quick, backend=args.backend, bands=args.bands
    )
    print(f"done in {time.perf_counter() - start:.1f} s; outputs in {report.out}/:")
    for path in report.files:
        print(f"  {path}")
    errors = report.errors + [f for ex in report.examples for f in ex.failures]
    for line in errors:
        print(f"error: {line}", file=sys.stderr)
    return 0 if not errors else 1
