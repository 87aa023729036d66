"""Command line: parse arguments, call the public API, report.

Input: argv. Output: files (emitted code, trajectories) and a short report on stdout. Bad
input (a spec, an option, an output path, a request the machine cannot serve, an initial state
where the energy is not finite) is one line on stderr naming what is wrong, with exit status
2, found before any integration starts and before anything is written; a failed integration
is one line with exit status 1, and its partial trajectory is still saved; so is a C library
that cannot be built (no C compiler). A run whose relative energy error passes --energy-warn
ends with a one-line warning and exit status 0. Every SPEC takes parameter values after a
colon (double_pendulum:g=5) or as --param g=5. Files
are written through a temporary file moved into place, never through a symbolic link.

Only the standard library and the method table are imported up front; each subcommand imports
what it needs (SymPy, NumPy, an experiment) when it runs, so `s2gen --help` stays fast.

Commands: generate, simulate, list, regen, reproduce, compare-angles, bench, ensemble, fmu. `s2gen COMMAND
--help` documents each.

Example:
    >>> main(["list"])  # doctest: +ELLIPSIS
    dipoles...
    0
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from s2gen.methods import BACKENDS, CONTROLS, LANGUAGES, NAMES

__all__ = ["main"]

#: Seconds a `simulate` run goes before its progress bar appears.
PROGRESS_DELAY = 2.0


class _Parser(argparse.ArgumentParser):
    """argparse with its errors as one line on stderr (status 2), not usage plus error."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


def _parser() -> argparse.ArgumentParser:
    from s2gen.ensemble.command import add_parser as add_ensemble
    from s2gen.experiments.bench.command import add_parser as add_bench
    from s2gen.experiments.compare_angles.command import add_parser as add_compare
    from s2gen.experiments.reproduce.command import add_parser as add_reproduce
    from s2gen.fmi.command import add_parser as add_fmu
    from s2gen.lyapunov_command import add_parser as add_lyapunov

    p = _Parser(
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
    g.add_argument(
        "--jacobians",
        action="store_true",
        help="also emit step_jacobian() and field_jacobian(), one step's and the field's exact "
        "derivatives (C and NumPy; up to 32 bodies), and in C step_jvp(), O(n) "
        "Jacobian-vector products (diagonal or structured M, any n)",
    )
    g.add_argument(
        "--batch",
        action="store_true",
        help="C: also emit integrate_batch(), K members per call (closed systems in SIMD lanes, "
        "driven ones member by member)",
    )

    s = sub.add_parser("simulate", help="integrate a system and save the trajectory (.npz)")
    s.add_argument("spec", metavar="SPEC")
    s.add_argument("--method", choices=NAMES, help="integrator (default: spec's [run], or vi)")
    s.add_argument("--backend", choices=BACKENDS, default="c", help="default c")
    s.add_argument(
        "--h", type=float, help="step size (RK45, DOP853: output spacing); default [run] h"
    )
    s.add_argument("--T", type=float, help="final time; default [run] T")
    s.add_argument("--rtol", type=float, help="RK45/DOP853 relative tolerance (default 1e-3)")
    s.add_argument("--atol", type=float, help="RK45/DOP853 absolute tolerance (default 1e-6)")
    s.add_argument(
        "--control",
        choices=CONTROLS,
        default="matlab",
        help="RK45 error control: MATLAB ode45's (default) or Hairer's/scipy's",
    )
    s.add_argument(
        "--max-steps",
        type=int,
        default=100000,
        metavar="N",
        help="RK45/DOP853 step budget: stop after N attempted steps between two samples "
        "(0: no limit); default 100000",
    )
    s.add_argument(
        "--every",
        type=int,
        default=1,
        metavar="K",
        help="keep every K-th step (T/h a multiple of K; energy only at kept samples); default 1",
    )
    s.add_argument(
        "--opt",
        choices=("portable", "native"),
        help="gcc flags of the C library: portable (default: -O2 with SIMD hints, runs on any "
        "machine) or native (-O3 -march=native -fno-tree-slp-vectorize: this processor only); or set S2GEN_OPT",
    )
    s.add_argument(
        "--out",
        help="trajectory file, written exactly as named (.npz format: t, q, omega, energy, "
        "angular_momentum, metadata; see s2gen.Trajectory.load); default: not saved, the "
        "statistics are printed",
    )
    _add_param(s)
    s.add_argument(
        "--energy-warn",
        type=float,
        default=1e-2,
        metavar="R",
        help="warn when the relative energy error |E - E0| / S passes R (S = K0 + |V0| + "
        "tangential |grad V| at t = 0; see s2gen.runtime.diagnostics); default 1e-2, 0 or inf: "
        "never",
    )
    s.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help=f"progress bar on stderr for runs longer than {PROGRESS_DELAY:g} s (default: on "
        "when stderr is a terminal)",
    )
    s.add_argument("--t0", type=float, default=0.0, help="start time (default 0)")
    s.add_argument(
        "--input",
        action="append",
        default=[],
        metavar="NAME=EXPR",
        help="a driven system's input as an expression in t and the parameters, evaluated at "
        "the start of each step and held over it (repeatable; other inputs keep their defaults)",
    )
    s.add_argument(
        "--inputs",
        metavar="FILE.csv",
        help="a driven system's inputs, one row per step: a header line naming the inputs, "
        "then one line of numbers per step (steps = T / h)",
    )

    sub.add_parser("list", help="list the built-in systems")

    r = sub.add_parser("regen", help="rewrite the emitted code kept in generated/")
    r.add_argument(
        "--out",
        default="generated",
        help="the generated/ folder of an s2gen checkout (default generated)",
    )

    add_reproduce(sub)
    add_compare(sub)
    add_bench(sub)
    add_ensemble(sub)
    add_fmu(sub)
    add_lyapunov(sub)
    return p


def _add_param(parser: argparse.ArgumentParser) -> None:
    """--param NAME=VALUE (repeatable) on a command that runs a system."""
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a parameter value (repeatable), as SPEC:NAME=VALUE; default the spec's",
    )


def _version() -> str:
    from s2gen.version import __version__

    return __version__


def _generate(args: argparse.Namespace) -> int:
    from s2gen.emit import emit, write_files
    from s2gen.paths import OutputPathError
    from s2gen.systems import resolve

    system = resolve(args.spec)
    if args.jacobians:
        from s2gen.equations.jacobian import jacobian_refusal
        from s2gen.equations.jvp import jvp_refusal

        why = jacobian_refusal(system)
        if why is not None and jvp_refusal(system) is not None:
            raise ValueError(f"--jacobians: {system.name}: {why}")
        system = system.with_jacobians()
    if args.batch:
        from s2gen.parts.batch import batch_refusal

        why = None if system.driven else batch_refusal(system)  # driven: s2gen.parts.batch_driven
        if why is not None:
            raise ValueError(f"--batch: {why}")
        system = system.with_batch()
    start = time.perf_counter()
    try:
        paths = write_files(emit(system, args.lang), args.out)
    except OutputPathError as exc:
        raise ValueError(f"--out {exc}") from None
    print(f"{system.name}: {len(paths)} file(s) in {time.perf_counter() - start:.2f} s")
    for path in paths:
        print(f"  {path}  ({path.stat().st_size} bytes)")
    return 0


def _simulate(args: argparse.Namespace) -> int:
    from s2gen.simulate_command import simulate_command

    return simulate_command(args, PROGRESS_DELAY)


def _list(args: argparse.Namespace) -> int:
    from s2gen.systems import builtin, builtin_names, builtin_options

    for name in builtin_names():
        s = builtin(name)
        options = ", ".join(str(o) for o in builtin_options(name))
        print(f"{name}  (n = {s.n}, {s.structure.kind.value} inertia)")
        if options:
            print(f"    options: {options}")
    return 0


def _checkout_root(target: Path) -> Path | None:
    """The s2gen checkout that `target` is the generated/ folder of, or None."""
    if target.name != "generated" or not target.is_dir():
        return None
    root = target.resolve().parent
    project = root / "pyproject.toml"
    try:
        text = project.read_text(encoding="utf-8")
    except OSError:
        return None
    return root if 'name = "s2gen"' in text else None


def _regen(args: argparse.Namespace) -> int:
    from s2gen.emit import regenerate

    target = Path(args.out)
    if _checkout_root(target) is None:
        raise ValueError(
            f"regen: {target} is not the generated/ folder of an s2gen checkout (a folder "
            "'generated' beside the checkout's pyproject.toml); run it from the repository "
            "root or give --out CHECKOUT/generated"
        )
    paths = regenerate(target)
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


def _ensemble(args: argparse.Namespace) -> int:
    from s2gen.ensemble.driver import run

    if not args.chaos_band:
        return run(args)
    from s2gen.experiments.reproduce.band import run_band

    return run(args, chaos_band=run_band)


def _fmu(args: argparse.Namespace) -> int:
    from s2gen.fmi.command import run

    return run(args)


def _lyapunov(args: argparse.Namespace) -> int:
    from s2gen.lyapunov_command import lyapunov_command

    return lyapunov_command(args)


_COMMANDS = {
    "generate": _generate,
    "simulate": _simulate,
    "list": _list,
    "regen": _regen,
    "reproduce": _reproduce,
    "compare-angles": _compare_angles,
    "bench": _bench,
    "ensemble": _ensemble,
    "fmu": _fmu,
    "lyapunov": _lyapunov,
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


def _check_cache() -> None:
    """The build cache folder must be a folder a file can be created in (ValueError)."""
    from s2gen.paths import OutputPathError, check_output_file

    root = os.environ.get("S2GEN_CACHE", str(Path.home() / ".cache" / "s2gen"))
    try:
        check_output_file(Path(root) / "probe")
    except OutputPathError as exc:
        raise ValueError(f"build cache S2GEN_CACHE={root} is unusable: {exc}") from None


class DerivationStages(logging.Handler):
    """Prints each stage of a derivation (logger ``s2gen.derive``) as one line on `stream`
    once the derivation has gone `delay` seconds, so a long one shows where it is.

    Example:
        >>> import io
        >>> out = io.StringIO()
        >>> h = DerivationStages(out, delay=2.0)
        >>> for since in (0.5, 2.5):
        ...     h.handle(logging.makeLogRecord({"msg": "rope: pass cse done", "since": since}))
        True
        True
        >>> print(out.getvalue().strip())
        deriving rope: pass cse done (2.5 s)
    """

    def __init__(self, stream: Any, delay: float = PROGRESS_DELAY) -> None:
        super().__init__(logging.INFO)
        self.stream, self.delay = stream, delay

    def emit(self, record: logging.LogRecord) -> None:
        since = float(getattr(record, "since", 0.0))
        if since >= self.delay:
            print(f"deriving {record.getMessage()} ({since:.1f} s)", file=self.stream, flush=True)


def _show_stages() -> Callable[[], None]:
    """On a terminal, derivation stages on stderr (`DerivationStages`); returns the undo."""
    if not getattr(sys.stderr, "isatty", lambda: False)():
        return lambda: None
    logger = logging.getLogger("s2gen.derive")
    handler = DerivationStages(sys.stderr, delay=PROGRESS_DELAY)
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)

    def undo() -> None:
        logger.removeHandler(handler)
        logger.setLevel(level)

    return undo


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `s2gen` command: the exit status (0 ok, 1 failed integration,
    2 bad input), every error one line on stderr.

    Example:
        >>> main(["simulate", "double_pendulum", "--h", "0", "--out", "x.npz"])
        2
        >>> main(["simulate", "double_pendulum:g=1.62", "--T", "0.1"])  # doctest: +ELLIPSIS
        double_pendulum: integrating with vi on c (h=0.01, T=0.1) ...
        ...
        0
    """
    warnings.showwarning = _show_warning
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code if isinstance(exc.code, int) else 2
    undo = _show_stages()
    try:
        if args.command != "list":
            _check_cache()
        return _COMMANDS[args.command](args)
    except ValueError as exc:  # SpecError is a ValueError: bad input, one line, status 2
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # no C compiler, or gcc refused the code: status 1
        from s2gen.build import BuildError

        if not isinstance(exc, BuildError):
            raise
        print(f"error: cannot build the C library: {exc} (s2gen simulate --backend numpy needs none)",
              file=sys.stderr)  # fmt: skip
        return 1
    except OSError as exc:  # a file or folder the command needed, named by the OS
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    finally:
        undo()


if __name__ == "__main__":
    sys.exit(main())
