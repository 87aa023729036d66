"""The `s2gen fmu` command line: its parser (standard library only) and its run.

Input: an argparse subparsers object, or parsed arguments. Output: the registered `fmu`
subcommand; the .fmu file written and one line saying what it holds.

Example:
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> a = p.parse_args(["fmu", "double_pendulum", "--out", "dp.fmu", "--fmi", "3"])
    >>> a.fmi, a.kind, a.method
    (3, None, 'vi')
"""

from __future__ import annotations

import argparse
import time
from typing import Any

__all__ = ["add_parser", "run"]

_EPILOG = """\
examples:
  s2gen fmu double_pendulum --out double_pendulum.fmu
  s2gen fmu double_pendulum:g=1.62 --out moon.fmu --fmi 3 --kind cs --method vi4
  fmpy simulate double_pendulum.fmu --stop-time 10 --show-plot
  s2gen fmu kapitza --out kapitza.fmu --method vi4
"""


def add_parser(subparsers: Any) -> None:
    """Register `s2gen fmu` on an argparse subparsers object."""
    from s2gen.methods import NAMES

    p = subparsers.add_parser(
        "fmu",
        help="export a system as a Functional Mock-up Unit (FMI 2 or 3)",
        description="Write SPEC as an FMU: model description, sources (a source FMU) and a "
        "binary for this machine. Co-Simulation advances each communication interval by "
        "--method's steps of size h (the FMU's stepSize parameter); Model Exchange gives the "
        "continuous (q, w) field to the importer's solver. A driven system (forces, inputs or "
        "time t) has FMI inputs, held over each step, and the output `work` (the work done on "
        "it, in Co-Simulation). Needs FMPy's FMI headers (pip install fmpy).",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("spec", metavar="SPEC")
    p.add_argument("--out", required=True, help="the .fmu file to write")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version (default 2)")
    p.add_argument(
        "--kind",
        choices=("cs", "me", "both"),
        help="Co-Simulation, Model Exchange or both (default both; cs for a driven system)",
    )
    p.add_argument(
        "--method", choices=NAMES, default="vi", help="Co-Simulation's method (default vi)"
    )
    p.add_argument("--h", type=float, help="Co-Simulation sub-step (default: the spec's [run] h)")
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a parameter's default value (repeatable), as SPEC:NAME=VALUE",
    )


def run(args: argparse.Namespace) -> int:
    """Write the FMU that `args` ask for; 0 on success (bad input raises ValueError)."""
    from s2gen.fmi import export
    from s2gen.paths import OutputPathError, check_output_file
    from s2gen.systems import resolve

    try:
        out = check_output_file(args.out)
    except OutputPathError as exc:
        raise ValueError(f"--out {exc}") from None
    system = resolve(args.spec, args.param)
    start = time.perf_counter()
    path = export(system, out, fmi=args.fmi, kind=args.kind, method=args.method, h=args.h)
    kind = args.kind or ("cs" if system.driven else "both")
    print(
        f"{system.name}: FMI {args.fmi} FMU ({kind}, {args.method}) in "
        f"{time.perf_counter() - start:.2f} s: {path} ({path.stat().st_size} bytes)"
    )
    return 0
