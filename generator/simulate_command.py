"""The `s2gen simulate` command: integrate a system, report the run, save the trajectory.

Input: the parsed command line (`s2gen.cli`). Output: the exit status, the report on stdout
(integrator counts, energy and unit-length errors, wall time), warnings after it, the
trajectory in `--out`. Bad input raises ValueError before anything runs (the command line
prints it in one line with status 2).

Example:
    >>> import argparse
    >>> args = argparse.Namespace(spec="double_pendulum", param=[], method=None, rtol=None,
    ...     atol=None, control="matlab", energy_warn=1e-2, h=0.0, T=1.0, backend="c", every=1,
    ...     out=None, opt=None, progress=False)
    >>> simulate_command(args, 2.0)
    Traceback (most recent call last):
    ...
    ValueError: step size h = 0: must be positive
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path
from typing import Any

from s2gen.methods import method as method_record

__all__ = ["simulate_command"]


def _report(name: str, tr: Any, out: Path | None) -> None:
    """Integrator counts, energy and unit-length errors, and the file written."""
    from s2gen import metrics
    from s2gen.runtime.trajectory import stat_counts

    c = stat_counts(tr.stats, tr.method)
    m = metrics.summary(tr.q, tr.energy)
    rejected = f" (+{c['rejected']} rejected)" if method_record(tr.method).adaptive else ""
    grads = "uncounted" if c["gradient_evals"] is None else str(c["gradient_evals"])
    print(
        f"{name}: {tr.method} on {tr.backend}, {c['steps']} steps{rejected}, "
        f"{grads} gradient evaluations, {c['newton_iters']} Newton iterations, "
        f"in {tr.wall_time:.3f} s"
    )
    if tr.work is None:
        print(f"  |E - E0|          mean {m['mean_dE']:.4e}   max {m['max_dE']:.4e}")
    else:
        balance = abs(tr.balance)
        print(
            f"  work W(T)         {tr.work[-1]:.6g}   (E(T) - E0 = {tr.balance[-1] + tr.work[-1]:.6g})"
        )
        print(f"  |E - E0 - W|      mean {balance.mean():.4e}   max {balance.max():.4e}")
    print(f"  | |q| - 1 |       mean {m['mean_norm']:.4e}   max {m['max_norm']:.4e}")
    print(f"  | q.q - 1 |       mean {m['mean_dot']:.4e}   max {m['max_dot']:.4e}")
    if out is None:
        print(f"  not saved ({len(tr.t)} samples; give --out FILE to keep them)")
    else:
        driven = "" if tr.work is None else ", work, inputs"
        print(f"  saved {out} ({len(tr.t)} samples: t, q, omega, energy, angular_momentum{driven})")


def _progress_on(args: argparse.Namespace) -> bool:
    """--progress / --no-progress, else on when stderr is a terminal."""
    if args.progress is not None:
        return bool(args.progress)
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


def _integrate(
    be: Any,
    method: str,
    h: float,
    T: float,
    opts: Any,
    show: bool,
    every: int,
    delay: float,
    drive: dict[str, Any],
) -> Any:
    """One run keeping every `every`-th step (`drive`: a driven run's t0 and inputs); when
    `show`, a progress bar (steps, rate, time left) on stderr once the run has gone `delay`
    seconds. The run is one call either way: the bar only reads how far it has come."""
    from s2gen.runtime import run

    if not show:
        return run(be, method, h, T, opts, every=every, **drive)
    from tqdm import tqdm

    steps = round(T / h)
    with tqdm(
        total=steps, desc=f"{be.system.name} {method}", unit="step", unit_scale=True,
        file=sys.stderr, delay=delay, leave=False,
    ) as bar:  # fmt: skip

        def progress(fraction: float) -> None:
            bar.update(int(steps * fraction) - bar.n)

        return run(be, method, h, T, opts, every=every, progress=progress, **drive)


def _output_file(path: str) -> Path:
    """--out checked before any work: a writable regular file, not through a symlink."""
    from s2gen.paths import OutputPathError, check_output_file

    try:
        return check_output_file(path)
    except OutputPathError as exc:
        raise ValueError(f"--out {exc}") from None


def simulate_command(args: argparse.Namespace, delay: float) -> int:
    """Carry out `s2gen simulate` (exit status 0, 1 for a failed integration with its valid
    samples kept; bad input raises ValueError); a progress bar after `delay` seconds."""
    from s2gen.runtime import IntegrationError, Options, check_run, get_backend
    from s2gen.systems import resolve

    system = resolve(args.spec, args.param)
    method = args.method or system.run.method or "vi"
    opts = Options(
        rtol=args.rtol if args.rtol is not None else (system.run.rtol or 1e-3),
        atol=args.atol if args.atol is not None else (system.run.atol or 1e-6),
        control=args.control,
        energy_warn=args.energy_warn,
        max_steps=getattr(args, "max_steps", 100000),
    )
    h = args.h if args.h is not None else system.run.h
    T = args.T if args.T is not None else system.run.T
    if h is None or T is None:
        raise ValueError(f"{system.origin}: no step size h or final time T (give --h and --T)")
    from s2gen.methods import check_method

    check_method(method, args.backend)
    nsteps = check_run(system, method, h, T, opts, args.every)  # what the machine cannot serve
    from s2gen.input_options import cli_inputs

    t0 = getattr(args, "t0", 0.0)
    given = getattr(args, "input", []) or []
    drive = {
        "t0": t0,
        "inputs": cli_inputs(system, given, getattr(args, "inputs", None), nsteps, h, t0),
    }
    out = None if args.out is None else _output_file(args.out)  # an unwritable file: refused now
    if args.opt:
        os.environ["S2GEN_OPT"] = args.opt
    be = get_backend(system, args.backend)
    print(
        f"{system.name}: integrating with {method} on {args.backend} (h={h}, T={T}) ...", flush=True
    )
    with warnings.catch_warnings(record=True) as caught:  # shown after the report
        warnings.simplefilter("always")
        try:
            tr = _integrate(be, method, h, T, opts, _progress_on(args), args.every, delay, drive)
        except IntegrationError as exc:
            if out is None:
                print(f"error: {exc} (give --out FILE to save them)", file=sys.stderr)
            else:
                exc.partial.save(out)
                print(f"error: {exc}; saved them to {out}", file=sys.stderr)
            return 1
    written = None if out is None else tr.save(out)
    _report(system.name, tr, written)
    for w in caught:
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    return 0
