"""Command line: parse arguments, call the pipeline, report.

Input: argv. Output: files (emitted code, trajectories) and a short report on stdout; errors
in the spec or the run are printed as one clear line with exit status 2 (1 for a failed
integration, whose partial trajectory is still saved).

Commands: generate, simulate, list, regen, reproduce, compare-angles, bench. `s2gen COMMAND --help` documents each.

Example:
    >>> main(["list"])  # doctest: +ELLIPSIS
    dipoles...
    0
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from s2gen import metrics
from s2gen.emit import LANGUAGES, emit, write_files
from s2gen.experiments import bench, compare_angles
from s2gen.runtime import BACKENDS, CONTROLS, METHODS, IntegrationError, Options, simulate
from s2gen.system import SpecError, System
from s2gen.systems import builtin, builtin_names, resolve

__all__ = ["GENERATED_SYSTEMS", "main", "regenerate"]

#: Built-in systems whose emitted code is kept in the repository's generated/ folder.
GENERATED_SYSTEMS = ("double_pendulum",)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="s2gen",
        description="Equations, variational integrators and C/NumPy code for mechanics on "
        "(S^2)^n. SPEC is a TOML file or the name of a built-in system (s2gen list).",
    )
    sub = p.add_subparsers(dest="command", required=True)

    g = sub.add_parser("generate", help="write the emitted C or NumPy code of a system")
    g.add_argument("spec", metavar="SPEC")
    g.add_argument("--lang", choices=LANGUAGES, default="c", help="language (default c)")
    g.add_argument("--out", required=True, help="output folder (created if needed)")

    s = sub.add_parser("simulate", help="integrate a system and save the trajectory (.npz)")
    s.add_argument("spec", metavar="SPEC")
    s.add_argument("--method", choices=METHODS, help="integrator (default: spec's [run], or vi)")
    s.add_argument("--backend", choices=BACKENDS, default="c", help="default c")
    s.add_argument("--h", type=float, help="step size (RK45: output spacing); default [run] h")
    s.add_argument("--T", type=float, help="final time; default [run] T")
    s.add_argument("--rtol", type=float, help="RK45 relative tolerance (default 1e-3)")
    s.add_argument("--atol", type=float, help="RK45 absolute tolerance (default 1e-6)")
    s.add_argument(
        "--control",
        choices=CONTROLS,
        default="matlab",
        help="RK45 error control: MATLAB ode45's (default) or Hairer's/scipy's",
    )
    s.add_argument("--out", required=True, help="trajectory file (.npz: t, q, omega, energy)")

    sub.add_parser("list", help="list the built-in systems")

    r = sub.add_parser("regen", help="rewrite the emitted code kept in generated/")
    r.add_argument("--out", default="generated", help="folder (default generated)")

    _reproduce_parser(sub)
    compare_angles.add_parser(sub)
    bench.add_parser(sub)
    return p


def _reproduce_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from s2gen.experiments.paper import EXAMPLES

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
    rp.add_argument("--quick", action="store_true", help="shortened runs (about a minute)")
    rp.add_argument("--backend", choices=BACKENDS, default="c", help="default c")


def regenerate(out: str | Path) -> list[Path]:
    """Write the C and NumPy code of `GENERATED_SYSTEMS` under out/<system>/<lang>/."""
    paths: list[Path] = []
    for name in GENERATED_SYSTEMS:
        system = builtin(name)
        for lang in LANGUAGES:
            paths += write_files(emit(system, lang), Path(out) / name / lang)
    return paths


def _generate(args: argparse.Namespace) -> int:
    system = resolve(args.spec)
    start = time.perf_counter()
    paths = write_files(emit(system, args.lang), args.out)
    print(f"{system.name}: {len(paths)} file(s) in {time.perf_counter() - start:.2f} s")
    for path in paths:
        print(f"  {path}  ({path.stat().st_size} bytes)")
    return 0


def _report(
    system: System,
    tr_method: str,
    backend: str,
    q: np.ndarray,
    energy: np.ndarray,
    steps: int,
    wall: float,
) -> None:
    m = metrics.summary(q, energy)
    print(f"{system.name}: {tr_method} on {backend}, {steps} steps in {wall:.3f} s")
    print(f"  |E - E0|          mean {m['mean_dE']:.4e}   max {m['max_dE']:.4e}")
    print(f"  | |q| - 1 |       mean {m['mean_norm']:.4e}   max {m['max_norm']:.4e}")
    print(f"  | q.q - 1 |       mean {m['mean_dot']:.4e}   max {m['max_dot']:.4e}")


def _simulate(args: argparse.Namespace) -> int:
    system = resolve(args.spec)
    method = args.method or system.run.method or "vi"
    opts = Options(
        rtol=args.rtol if args.rtol is not None else (system.run.rtol or 1e-3),
        atol=args.atol if args.atol is not None else (system.run.atol or 1e-6),
        control=args.control,
    )
    h = args.h if args.h is not None else system.run.h
    T = args.T if args.T is not None else system.run.T
    print(
        f"{system.name}: integrating with {method} on {args.backend} (h={h}, T={T}) ...", flush=True
    )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        tr = simulate(system, method, args.backend, h=h, T=T, options=opts)
    except IntegrationError as exc:
        p = exc.partial
        np.savez(out, t=p.t, q=p.q, omega=p.omega, energy=p.energy)
        print(f"error: {exc}\n  partial trajectory saved to {out}", file=sys.stderr)
        return 1
    np.savez(out, t=tr.t, q=tr.q, omega=tr.omega, energy=tr.energy)
    _report(system, method, args.backend, tr.q, tr.energy, len(tr.t) - 1, tr.wall_time)
    print(f"  saved {out} (t, q, omega, energy; {len(tr.t)} samples)")
    return 0


def _reproduce(args: argparse.Namespace) -> int:
    from s2gen.experiments.reproduce import reproduce

    start = time.perf_counter()
    report = reproduce(args.examples, args.out, quick=args.quick, backend=args.backend)
    print(f"done in {time.perf_counter() - start:.1f} s; outputs in {report.out}/:")
    for path in report.files:
        print(f"  {path}")
    errors = report.errors + [f for ex in report.examples for f in ex.failures]
    for line in errors:
        print(f"error: {line}", file=sys.stderr)
    return 0 if not errors else 1


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: object = None,
    line: str | None = None,
) -> None:
    """Warnings as one plain line (the spec's corrections are for users, not tracebacks)."""
    print(f"warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `s2gen` command."""
    warnings.showwarning = _show_warning
    args = _parser().parse_args(argv)
    try:
        if args.command == "generate":
            return _generate(args)
        if args.command == "simulate":
            return _simulate(args)
        if args.command == "reproduce":
            return _reproduce(args)
        if args.command == "compare-angles":
            return compare_angles.run(args)
        if args.command == "bench":
            return bench.run(args)
        if args.command == "list":
            for name in builtin_names():
                s = builtin(name)
                kind = "coupled" if not s.is_diagonal else "diagonal"
                print(f"{name}  (n = {s.n}, {kind} inertia)")
            return 0
        paths = regenerate(args.out)
        print(f"rewrote {len(paths)} files under {args.out}/")
        return 0
    except (SpecError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
