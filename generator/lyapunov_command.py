"""The `s2gen lyapunov` command: a system's Lyapunov spectrum, its convergence and a CSV.

Input: the parsed command line (`s2gen.cli`). Output: the exit status and, on stdout, the
spectrum (each exponent with its statistical error, the pair sums lambda_k + lambda_(4n+1-k)
and the total), from `Model.lyapunov` (`s2gen.runtime.lyapunov`) on the C (default), NumPy or
reference backend; with `--out DIR`, the running estimates against the averaging time in
DIR/lyapunov.csv and their plot in DIR/lyapunov.png. Bad input raises ValueError before the run (one line, status 2).

Example:
    >>> import argparse
    >>> args = argparse.Namespace(spec="double_pendulum", param=[], method="vi", h=-1.0,
    ...     T=1.0, transient=0.0, blocks=10, out=None, progress=False, backend="c")
    >>> lyapunov_command(args)
    Traceback (most recent call last):
    ...
    ValueError: h = -1.0: must be positive
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

__all__ = ["add_parser", "lyapunov_command"]


def add_parser(subparsers: Any) -> None:
    """Register `s2gen lyapunov` on an argparse subparsers object."""
    from s2gen.methods import BACKENDS, NAMES

    p = subparsers.add_parser(
        "lyapunov",
        help="the Lyapunov spectrum of a system's steps, from their exact Jacobians",
        description="The Lyapunov spectrum of METHOD's discrete flow from the spec's initial "
        "state: QR re-orthonormalization of the products of exact step Jacobians in the "
        "tangent coordinates of T(S^2)^n (4n exponents), a transient discarded, errors from "
        "block means. The systems `s2gen generate --jacobians` covers (a bounded number of "
        "bodies, no cutoff terms); the VI family, the fixed-step Runge-Kutta methods and (a "
        "closed system) the RATTLE family.",
    )
    p.add_argument("spec", metavar="SPEC")
    p.add_argument("--method", choices=NAMES, default="vi", help="integrator (default vi)")
    p.add_argument(
        "--backend",
        choices=BACKENDS,
        default="c",
        help="c (default), numpy, or reference: the complex-step Jacobians of the reference "
        "step (slow, an independent check)",
    )
    p.add_argument("--h", type=float, help="step size (default: the spec's [run] h)")
    p.add_argument("--T", type=float, help="averaging time (default: the spec's [run] T)")
    p.add_argument("--transient", type=float, help="time discarded first (default: a tenth of T)")
    p.add_argument(
        "--blocks", type=int, default=10, help="blocks of the statistical error (default 10)"
    )
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a parameter value (repeatable); default the spec's",
    )
    p.add_argument(
        "--out", help="folder for lyapunov.csv (running estimates) and lyapunov.png (their plot)"
    )
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: on when stderr is a terminal)",
    )


def _out_dir(out: str | None) -> Path | None:
    """--out checked before the run: a folder the two files can be written in."""
    if out is None:
        return None
    from s2gen.paths import OutputPathError, check_output_file

    try:
        for name in ("lyapunov.csv", "lyapunov.png"):
            check_output_file(Path(out) / name)
    except OutputPathError as exc:
        raise ValueError(f"--out {exc}") from None
    return Path(out)


def _report(name: str, ls: Any) -> None:
    """The spectrum, the pair sums and the total, each with its error."""
    dim = len(ls.exponents)
    print(
        f"{name}: {ls.method}, h = {ls.h:g}, T = {ls.T:g} after a transient of "
        f"{ls.transient:g}; errors from {ls.blocks} block means"
    )
    for k, (lam, err) in enumerate(zip(ls.exponents, ls.error, strict=True), start=1):
        print(f"  lambda_{k:<3d} {lam:+.6f} +- {err:.6f}")
    for k, (s, err) in enumerate(zip(ls.pair_sums, ls.pair_error, strict=True), start=1):
        print(f"  lambda_{k} + lambda_{dim + 1 - k} = {s:+.6f} +- {err:.6f}")
    print(f"  sum       {ls.total:+.6f} +- {ls.total_error:.6f}")


def _write(out: Path, name: str, ls: Any) -> None:
    """lyapunov.csv (t, lambda_1 .. lambda_4n, the running estimates) and lyapunov.png."""
    from matplotlib.figure import Figure

    from s2gen.paths import write_text_atomic

    dim = len(ls.exponents)
    header = "t," + ",".join(f"lambda_{k}" for k in range(1, dim + 1))
    rows = [",".join(repr(float(x)) for x in (t, *r)) for t, r in zip(ls.times, ls.running)]
    write_text_atomic(out / "lyapunov.csv", "\n".join([header, *rows]) + "\n")
    fig = Figure(figsize=(8, 5))
    ax = fig.add_subplot()
    for k in range(dim):
        ax.plot(ls.times, ls.running[:, k], lw=0.8, label=rf"$\lambda_{{{k + 1}}}$")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("averaging time t (the spec's time unit)")
    ax.set_ylabel(r"running estimate of $\lambda_k$ (1 / time unit)")
    ax.grid(True, alpha=0.3)
    if dim <= 16:
        ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    fig.suptitle(f"{name}: Lyapunov spectrum, {ls.method}, h = {ls.h:g}")
    fig.tight_layout()
    fig.savefig(out / "lyapunov.png", dpi=120)
    print(f"  wrote {out / 'lyapunov.csv'} and {out / 'lyapunov.png'}")


def lyapunov_command(args: argparse.Namespace) -> int:
    """Carry out `s2gen lyapunov` (exit status 0; bad input or a failed step raise
    ValueError)."""
    from s2gen.runtime.lyapunov import check_lyapunov
    from s2gen.runtime.model import Model
    from s2gen.systems import resolve

    system = resolve(args.spec, args.param)
    h = args.h if args.h is not None else system.run.h
    T = args.T if args.T is not None else system.run.T
    if h is None or T is None:
        raise ValueError(f"{system.origin}: no step size h or final time T (give --h and --T)")
    transient = args.transient if args.transient is not None else T / 10
    check_lyapunov(h, T, transient, args.blocks, 1)
    out = _out_dir(args.out)
    model = Model(system, backend=args.backend)
    show = args.progress
    if show is None:
        show = bool(getattr(sys.stderr, "isatty", lambda: False)())
    start = time.perf_counter()
    if show:
        from tqdm import tqdm

        steps = round((T + transient) / h)
        with tqdm(total=steps, desc=f"{system.name} lyapunov", unit="step", unit_scale=True,
                  file=sys.stderr, leave=False) as bar:  # fmt: skip

            def progress(fraction: float) -> None:
                bar.update(int(steps * fraction) - bar.n)

            ls = model.lyapunov(system.q0, system.omega0, h, T, args.method, transient,
                                blocks=args.blocks, progress=progress)  # fmt: skip
    else:
        ls = model.lyapunov(system.q0, system.omega0, h, T, args.method, transient,
                            blocks=args.blocks)  # fmt: skip
    _report(system.name, ls)
    print(f"  in {time.perf_counter() - start:.2f} s")
    if out is not None:
        _write(out, system.name, ls)
    return 0
