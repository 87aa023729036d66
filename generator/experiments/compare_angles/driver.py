"""The `s2gen compare-angles` driver: run the whole comparison, write every file; the CLI.

Input: a `System` and `Settings` (Python: `compare`), or parsed arguments (`add_parser`,
`settings_from_args`, `run`). Output: a `Comparison` whose `files` are ``compare_angles.md``,
``compare_angles.json`` and the PNG figures written to the output folder (`write_all`);
progress lines go to `log`; `run` prints the files and returns an exit code.

Example:
    >>> import argparse
    >>> from s2gen.experiments.compare_angles.command import add_parser
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
from pathlib import Path

from s2gen import System

from .chains import scaling
from .command import settings_from_args
from .cost import _cost_line, costs
from .figures import accuracy_figure, pole_error_figure, pole_steps_figure, scaling_figure
from .model import Comparison
from .pole import pole_study
from .report import markdown, write_json
from .settings import FORMS, Settings
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


def run(args: argparse.Namespace) -> int:
    """Run `compare-angles` from parsed arguments; 0 on success."""
    from s2gen import load

    system = load(args.spec, args.param)
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
