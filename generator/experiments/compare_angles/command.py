"""The `s2gen compare-angles` command line: its parser and its settings (imports nothing heavy).

Input: an argparse subparsers object, or parsed arguments. Output: the registered
`compare-angles` subcommand; the `Settings` the parsed arguments ask for.

Example:
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> settings_from_args(p.parse_args(["compare-angles", "x", "--quick"])).chain_max
    3
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

from .settings import Settings

__all__ = ["add_parser", "settings_from_args"]


def add_parser(subparsers: Any) -> None:
    """Register `compare-angles` on an argparse subparsers object (wired in by cli.py)."""
    d = Settings()
    p = subparsers.add_parser(
        "compare-angles",
        help="compare the (S^2)^n form with the classical spherical-angle form",
        description="Generate both forms from the same system and compare derivation time, "
        "operations, code size, gcc time, time per vector-field evaluation and accuracy; "
        "study trajectories near a pole and chains of n pendula. Writes compare_angles.md, "
        "compare_angles.json and PNG figures.",
    )
    p.add_argument("spec", metavar="SPEC")
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a parameter value (repeatable), as SPEC:NAME=VALUE; default the spec's",
    )
    p.add_argument("--out", help="output folder (default out/compare_angles/<name>)")
    p.add_argument("--T", type=float, default=d.T, help=f"final time (default {d.T:g})")
    p.add_argument("--h", type=float, default=d.h, help=f"RK4 step, RK45 output grid ({d.h:g})")
    p.add_argument("--rtol", type=float, default=d.rtol, help=f"RK45 rtol (default {d.rtol:g})")
    p.add_argument("--atol", type=float, default=d.atol, help=f"RK45 atol (default {d.atol:g})")
    p.add_argument("--control", choices=("matlab", "hairer"), default=d.control)
    p.add_argument("--budget", type=float, default=d.budget, help="seconds per derivation")
    p.add_argument("--tilts", type=_floats, default=d.tilts, help="near-pole tilts, e.g. 1e-2,1e-4")
    p.add_argument("--alpha", type=float, default=d.alpha, help="near-pole back-up angle (rad)")
    p.add_argument("--chain-max", type=int, default=d.chain_max, help="largest chain (0: none)")
    p.add_argument("--repeats", type=int, default=d.repeats, help="timing repeats (best of)")
    p.add_argument("--quick", action="store_true", help="short runs (T 2, chains to 3)")


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}"
        ) from None


def settings_from_args(args: argparse.Namespace) -> Settings:
    """Settings from parsed arguments (`--quick` replaces the defaults it shortens)."""
    base = Settings.quick() if args.quick else Settings()
    given = {
        k: getattr(args, k)
        for k in ("T", "h", "rtol", "atol", "control", "budget", "alpha", "repeats", "tilts")
        if getattr(args, k) != getattr(Settings(), k)
    }
    if args.chain_max != Settings().chain_max:
        given["chain_max"] = args.chain_max
    return replace(base, **given)
