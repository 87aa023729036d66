"""The `s2gen ensemble` command: check the arguments, run with a progress bar, summarise.

Input: arguments parsed by `command.add_parser`. Output: the store and the summary files in
--out (or, with --bench, the benchmark's printed numbers; with --chaos-band, what the runner
passed in by the command line writes: band.md, band.png and band.csv); an exit code: 0 (failed integrations are results, counted in the summary), 1 when
a member's task raised, 2 on bad input (raised as a one-line ValueError for the CLI to print),
130 when interrupted (the members written so far stay in the store).

Example:
    >>> from s2gen.ensemble.command import add_parser
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> run(p.parse_args(["ensemble", "double_pendulum", "--sweep", "g=1:2"]))
    ... # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    ...
    s2gen.ensemble.members.EnsembleError: sweep g=1:2: expected START:STOP:COUNT (e.g. 100:1000:10) or a list V1,V2,...
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from s2gen.runtime.options import Options

from .cluster import needs_cluster
from .command import DEFAULT_OUT, command_line
from .members import EnsembleError, member_table, parse_assignment, sweep_values
from .requirements import require

__all__ = ["BandRun", "ProgressBar", "perturbations", "run", "sweeps"]

#: What runs `--chaos-band`: given the parsed arguments and the --perturb sizes, an exit code.
#: The paper examples the band needs belong to `s2gen reproduce`, so the command line passes
#: its runner in (`s2gen.experiments.reproduce.band.run_band`).
BandRun = Callable[[argparse.Namespace, dict[str, float]], int]


def perturbations(items: list[str]) -> dict[str, float]:
    """--perturb WHAT=SIZE arguments as {"q" | "omega": size}.

    Example:
        >>> perturbations(["omega=1e-13"])
        {'omega': 1e-13}
    """
    out = {}
    for item in items:
        name, value = parse_assignment(item, "--perturb")
        try:
            out[name] = float(value)
        except ValueError:
            raise EnsembleError(f"--perturb {item}: SIZE must be a number") from None
    return out


def sweeps(items: list[str]) -> dict[str, tuple[float, ...]]:
    """--sweep NAME=VALUES arguments as {name: values} (syntax checked here, names later)."""
    out = {}
    for item in items:
        name, value = parse_assignment(item, "--sweep")
        if name in out:
            raise EnsembleError(f"--sweep {name} given twice")
        out[name] = sweep_values(value, name)
    return out


def _security(args: argparse.Namespace) -> Any:
    """The Dask `Security` of --tls-ca-file, --tls-cert and --tls-key (None without them)."""
    given = [args.tls_ca_file, args.tls_cert, args.tls_key]
    if not any(given):
        return None
    if not (args.tls_ca_file and args.tls_cert):
        raise EnsembleError(
            "TLS needs both --tls-ca-file and --tls-cert (and --tls-key unless "
            "the certificate file holds the key)"
        )
    from .admission import tls_security

    return tls_security(args.tls_ca_file, args.tls_cert, args.tls_key)


def _options(args: argparse.Namespace) -> Options:
    return Options(rtol=args.rtol, atol=args.atol, control=args.control, max_steps=args.max_steps)


class ProgressBar:
    """A tqdm progress bar over members (an `ensemble` `progress` callback), drawn from the
    first member on (so that an error while connecting stays a single line), counting failed
    members.

    Example:
        >>> bar = ProgressBar(4, "double_pendulum")
        >>> bar.write("starting")
        starting
        >>> bar.close()
    """

    def __init__(self, total: int, desc: str) -> None:
        self.total, self.desc, self.failed = total, desc, 0
        self.bar: Any = None

    def __call__(self, result: Any) -> None:
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(
                total=self.total, desc=self.desc, unit="member", file=sys.stderr, dynamic_ncols=True
            )
        if result.status != 0:
            self.failed += 1
            self.bar.set_postfix(failed=self.failed, refresh=False)
        self.bar.update(1)

    def write(self, line: str) -> None:
        """Print a line without breaking the bar."""
        if self.bar is None:
            print(line, flush=True)
        else:
            self.bar.write(line)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run(args: argparse.Namespace, chaos_band: BandRun | None = None) -> int:
    """Carry out `s2gen ensemble` (see the module docstring for exit codes); `chaos_band`
    runs --chaos-band (without one, --chaos-band is refused)."""
    perturb = perturbations(args.perturb)
    sweep = sweeps(args.sweep)
    if args.bench and args.chaos_band:
        raise EnsembleError("--bench and --chaos-band are separate runs; give one")
    security = _security(args)
    if args.dashboard and (args.scheduler or args.workers == 0):
        raise EnsembleError(
            "--dashboard serves the local cluster's dashboard; a --scheduler serves its own, "
            "--workers 0 has none"
        )
    if (args.bench or args.chaos_band) and (security is not None or args.dashboard):
        raise EnsembleError(
            "--tls-* and --dashboard apply to ensemble runs, not to --bench or --chaos-band"
        )
    if args.bench:
        if sweep or args.param:
            raise EnsembleError(
                "--bench times perturbed members of SPEC as given; it takes no --sweep or "
                "--param (write SPEC:NAME=VALUE)"
            )
        require("zarr", *needs_cluster(args.scheduler, args.workers or 2))
        return _bench(args, perturb)
    if args.chaos_band:
        given = [f"--{k}" for k in ("method", "h", "T") if getattr(args, k) is not None]
        given += ["--param"] * bool(args.param)
        if sweep or given or args.every != 1:
            extra = ", ".join(
                given + (["--sweep"] if sweep else []) + (["--every"] * (args.every != 1))
            )
            raise EnsembleError(f"--chaos-band runs the paper example's own runs; drop {extra}")
        if chaos_band is None:
            raise EnsembleError("--chaos-band needs the paper examples of s2gen reproduce")
        require("zarr", *needs_cluster(args.scheduler, args.workers))
        return chaos_band(args, perturb)
    require("zarr", *needs_cluster(args.scheduler, args.workers))
    from s2gen.systems import resolve

    from .dispatch import check_sizes, ensemble
    from .store import EnsembleStore
    from .summary import summarize

    system = resolve(args.spec, args.param)
    table = member_table(system, args.members, perturb, sweep, args.seed, args.h, args.T)
    method = args.method or system.run.method or "vi"
    check_sizes(system, table, method, args.every, _options(args))  # before anything is built
    where = args.scheduler or (
        "this process (serial)"
        if args.workers == 0
        else f"{args.workers or 'one per core'} local worker process(es)"
    )
    tls = " over TLS" if security is not None else ""
    print(f"{system.name}: {len(table)} members on {where}{tls}; store {args.out}/", flush=True)
    if args.dashboard and args.scheduler is None and args.workers != 0:
        print(f"dashboard: http://{args.dashboard}/status", flush=True)
    bar = ProgressBar(len(table), system.name)
    try:
        result = ensemble(
            system,
            members=args.members,
            perturb=perturb,
            sweep=sweep,
            method=args.method,
            h=args.h,
            T=args.T,
            every=args.every,
            client=args.scheduler,
            workers=args.workers,
            out=args.out,
            seed=args.seed,
            options=_options(args),
            progress=bar,
            timeout=args.timeout,
            overwrite=args.overwrite,
            command=command_line(args),
            security=security,
            dashboard=args.dashboard,
            batch_size=args.batch_size,
        )
    except KeyboardInterrupt:
        bar.close()
        kept = _kept(args.out)
        print(f"interrupted: {kept} of {len(table)} members kept in {args.out}/", file=sys.stderr)
        return 130
    finally:
        bar.close()
    summary = summarize(EnsembleStore.open(result.path), args.out, result, not args.no_figures)
    print(
        f"{result.written} members in {result.wall_time:.2f} s (set-up {result.setup_time:.2f} s)"
        f" on {result.workers or 'no'} worker(s): {len(result.failed)} failed integrations, "
        f"{len(result.task_errors)} task errors"
    )
    for d in summary.divergences:
        if d.fit.rate is not None:
            print(f"  Lyapunov exponent (point {d.point}): {d.fit.rate:.4g}")
    print(f"  {result.path}")
    for path in summary.files:
        print(f"  {path}")
    return 1 if result.task_errors else 0


def _kept(out: str) -> int:
    from .store import EnsembleStore

    try:
        return int(EnsembleStore.open(out).written().sum())
    except Exception:  # noqa: BLE001 (a store not yet created keeps nothing)
        return 0


def _bench(args: argparse.Namespace, perturb: dict[str, float]) -> int:
    from .bench import benchmark

    report = benchmark(
        args.spec,
        members=args.members or 64,
        perturb=perturb or None,
        method=args.method,
        h=args.h,
        T=args.T,
        every=args.every,
        workers=args.workers or 2,
        options=_options(args),
        seed=args.seed,
        out=None if args.out == DEFAULT_OUT else args.out,
    )
    print(f"$ {command_line(args)}")
    for line in report.lines():
        print(line)
    return 0
