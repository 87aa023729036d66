"""The `s2gen compare-angles` driver: run the whole comparison, write every file; the CLI.

Input: a `System` and `Settings` (Python: `compare`), or parsed arguments (`add_parser`,
`settings_from_args`, `run`). Output: a `Comparison` whose `files` are ``compare_angles.md``,
``compare_angles.json`` and the PNG figures written to the output folder (`write_all`);
progress lines go to `log`; `run` prints the files and returns an exit code.

Example:
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> settings_from_args(p.parse_args(["compare-angles", "x.toml", "--quick"])).chain_max
    3
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from s2gen.system import System

from .chains import scaling
from .cost import _cost_line, costs
from .figures import accuracy_figure, pole_error_figure, pole_steps_figure, scaling_figure
from .model import FORMS, Comparison, Settings
from .pole import pole_study
from .report import markdown, write_json
from .trajectories import _run_line, accuracy, reference


def compare(
    system: System,
    s: Settings,
    out: str | Path,
    log: Callable[[str], None] = print,
) -> Comparison:
    """Run the whole comparison and write the report, the JSON numbers and the figures."""
    log(f"{system.name}: cost of each form (derivations in subprocesses, budget {s.budget:g} s)")
    spec_costs = costs(system, FORMS, s.budget, s.repeats)
    for c in spec_costs:
        log(f"  {c.form:18s} {_cost_line(c)}")
    assert system.q0 is not None and system.omega0 is not None
    log(f"{system.name}: accuracy over T = {s.T:g} (rtol {s.rtol:g}, atol {s.atol:g}, h {s.h:g})")
    state = (system.q0, system.omega0)
    acc = accuracy(system, s, state, reference(system, s, state))
    for r in acc:
        log(f"  {_run_line(r)}")
    log(f"{system.name}: near a pole (alpha {s.alpha:g}, tilts {list(s.tilts)})")
    pole = pole_study(system, s, log)
    if s.chain_max > 0:
        log(f"chains n = 1..{s.chain_max}:")
    chains = scaling(s, log)
    result = Comparison(system.name, system.n, s, spec_costs, acc, pole, chains)
    result.files = write_all(result, Path(out))
    return result


def write_all(result: Comparison, out: Path) -> list[Path]:
    """Write the figures, compare_angles.md and compare_angles.json into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    figures = [accuracy_figure(result, out / "accuracy.png")]
    if len(result.pole) > 1:
        figures.append(pole_steps_figure(result, out / "pole_steps.png"))
        figures.append(pole_error_figure(result, out / "pole_error.png"))
    if result.chains:
        figures.append(scaling_figure(result, out / "scaling.png"))
    md = out / "compare_angles.md"
    md.write_text(markdown(result, figures))
    return [md, write_json(result, out / "compare_angles.json"), *figures]


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


def run(args: argparse.Namespace) -> int:
    """Run `compare-angles` from parsed arguments; 0 on success."""
    from s2gen.systems import resolve

    system = resolve(args.spec)
    if system.q0 is None or system.omega0 is None:
        print(f"error: {system.origin}: no initial state ([initial] q and omega)", file=sys.stderr)
        return 2
    s = settings_from_args(args)
    out = Path(args.out or Path("out") / "compare_angles" / system.name)
    start = time.perf_counter()
    result = compare(system, s, out, log=lambda line: print(line, flush=True))
    print(f"done in {time.perf_counter() - start:.1f} s; outputs in {out}/:")
    for path in result.files:
        print(f"  {path}")
    return 0
