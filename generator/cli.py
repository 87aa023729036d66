"""Command line: parse arguments, call the public API, report.

Input: argv. Output: files (emitted code, trajectories) and a short report on stdout; errors
in the spec or the run are printed as one clear line with exit status 2 (1 for a failed
integration, whose partial trajectory is still saved).

Only the standard library and the method table are imported up front; each subcommand imports
what it needs (SymPy, NumPy, an experiment) when it runs, so `s2gen --help` stays fast.

Commands: generate, simulate, list, regen, reproduce, compare-angles, bench. `s2gen COMMAND
--help` documents each.

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
from typing import Any

from s2gen.methods import BACKENDS, CONTROLS, LANGUAGES, NAMES

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    from s2gen.experiments.bench.command import add_parser as add_bench
    from s2gen.experiments.compare_angles.command import add_parser as add_compare
    from s2gen.experiments.reproduce.command import add_parser as add_reproduce

    p = argparse.ArgumentParser(
        prog="s2gen",
        description="Equations, variational integrators and C/NumPy code for mechanics on "
        "(S^2)^n. SPEC is a TOML file or the name of a built-in system (s2gen list), with "
        "options after a colon: elastic_rod:n=1000, rope:n=200,kappa=0.1.",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="command", required=True)

    g = sub.add_parser("generate", help="write the emitted C or NumPy code of a system")
    g.add_argument("spec", metavar="SPEC")
    g.add_argument("--lang", choices=LANGUAGES, default="c", help="language (default c)")
    g.add_argument("--out", required=True, help="output folder (created if needed)")

    s = sub.add_parser("simulate", help="integrate a system and save the trajectory (.npz)")
    s.add_argument("spec", metavar="SPEC")
    s.add_argument("--method", choices=NAMES, help="integrator (default: spec's [run], or vi)")
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

    add_reproduce(sub)
    add_compare(sub)
    add_bench(sub)
    return p


def _version() -> str:
    from s2gen.version import __version__

    return __version__


def _generate(args: argparse.Namespace) -> int:
    from s2gen.emit import emit, write_files
    from s2gen.systems import resolve

    system = resolve(args.spec)
    start = time.perf_counter()
    paths = write_files(emit(system, args.lang), args.out)
    print(f"{system.name}: {len(paths)} file(s) in {time.perf_counter() - start:.2f} s")
    for path in paths:
        print(f"  {path}  ({path.stat().st_size} bytes)")
    return 0


def _report(name: str, method: str, backend: str, tr: Any) -> None:
    from s2gen import metrics

    m = metrics.summary(tr.q, tr.energy)
    print(f"{name}: {method} on {backend}, {len(tr.t) - 1} steps in {tr.wall_time:.3f} s")
    print(f"  |E - E0|          mean {m['mean_dE']:.4e}   max {m['max_dE']:.4e}")
    print(f"  | |q| - 1 |       mean {m['mean_norm']:.4e}   max {m['max_norm']:.4e}")
    print(f"  | q.q - 1 |       mean {m['mean_dot']:.4e}   max {m['max_dot']:.4e}")


def _simulate(args: argparse.Namespace) -> int:
    import numpy as np

    from s2gen.runtime import IntegrationError, Options, simulate
    from s2gen.systems import resolve

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
    _report(system.name, method, args.backend, tr)
    print(f"  saved {out} (t, q, omega, energy; {len(tr.t)} samples)")
    return 0


def _list(args: argparse.Namespace) -> int:
    from s2gen.systems import builtin, builtin_names, builtin_options

    for name in builtin_names():
        s = builtin(name)
        options = ", ".join(str(o) for o in builtin_options(name))
        print(f"{name}  (n = {s.n}, {s.structure.kind.value} inertia)")
        if options:
            print(f"    options: {options}")
    return 0


def _regen(args: argparse.Namespace) -> int:
    from s2gen.emit import regenerate

    paths = regenerate(args.out)
    print(f"rewrote {len(paths)} files under {args.out}/")
    return 0


def _reproduce(args: argparse.Namespace) -> int:
    from s2gen.experiments.reproduce.command import run

    return run(args)


def _compare_angles(args: argparse.Namespace) -> int:
    from s2gen.experiments.compare_angles.driver import run

    return run(args)


def _bench(args: argparse.Namespace) -> int:
    from s2gen.experiments.bench.driver import run

    return run(args)


_COMMANDS = {
    "generate": _generate,
    "simulate": _simulate,
    "list": _list,
    "regen": _regen,
    "reproduce": _reproduce,
    "compare-angles": _compare_angles,
    "bench": _bench,
}


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
        return _COMMANDS[args.command](args)
    except ValueError as exc:  # SpecError is a ValueError: bad input, one line, status 2
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
