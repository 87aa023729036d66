"""The `s2gen ensemble` command line: its parser and its canonical form (standard library only).

Input: an argparse subparsers object, or parsed arguments. Output: the registered `ensemble`
subcommand (the CLI then calls `driver.run`); the command line equivalent to parsed arguments.
The values of --perturb and --sweep are checked when the command runs, so that a bad one is
a single "error:" line with exit status 2.

Example:
    >>> p = argparse.ArgumentParser()
    >>> add_parser(p.add_subparsers(dest="command"))
    >>> a = p.parse_args(["ensemble", "elastic_rod", "--members", "8",
    ...                   "--perturb", "omega=1e-13", "--T", "0.3"])
    >>> command_line(a)
    's2gen ensemble elastic_rod --members 8 --perturb omega=1e-13 --T 0.3 --out out/ensemble'
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["DASHBOARD", "DEFAULT_OUT", "add_parser", "command_line"]

#: Output folder when --out is not given.
DEFAULT_OUT = "out/ensemble"
#: The local cluster's dashboard address when --dashboard is given without one.
DASHBOARD = "127.0.0.1:8787"

_EPILOG = """\
examples:
  s2gen ensemble elastic_rod --members 64 --perturb omega=1e-13 --T 3 --every 100
  s2gen ensemble double_pendulum --sweep g=1:20:8 --sweep h=0.01,0.02 --T 10
  dask scheduler --port 8786 &  dask worker tcp://HOST:8786 &
  s2gen ensemble elastic_rod --members 64 --perturb q=1e-13 --scheduler tcp://HOST:8786
  s2gen ensemble elastic_rod --members 64 --perturb q=1e-13 --scheduler tls://HOST:8786 \
      --tls-ca-file ca.pem --tls-cert me.pem --tls-key me.key
  s2gen ensemble elastic_rod --members 64 --perturb omega=1e-13 --T 3 --method vi --bench
  s2gen ensemble elastic_rod --chaos-band
"""


def add_parser(subparsers: Any) -> None:
    """Register `s2gen ensemble` on an argparse subparsers object.

    Example:
        >>> p = argparse.ArgumentParser()
        >>> add_parser(p.add_subparsers(dest="command"))
        >>> p.parse_args(["ensemble", "x", "--sweep", "kappa=1:2:3"]).sweep
        ['kappa=1:2:3']
    """
    e = subparsers.add_parser(
        "ensemble",
        help="run ensembles of perturbed initial states and parameter sweeps on Dask",
        description="Integrate many members of one system with the emitted C on a Dask "
        "cluster (a local one by default) and stream them into one Zarr store, "
        "DIR/ensemble.zarr; then write summary.md, members.csv and PNG figures to DIR.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    e.add_argument("spec", metavar="SPEC")
    e.add_argument(
        "--members",
        type=int,
        metavar="N",
        help="initial states per sweep point, member 0 the unperturbed reference "
        "(default 16 with --perturb, else 1)",
    )
    e.add_argument(
        "--perturb",
        action="append",
        default=[],
        metavar="WHAT=SIZE",
        help="relative perturbation of q or omega, e.g. omega=1e-13 (repeatable)",
    )
    e.add_argument(
        "--sweep",
        action="append",
        default=[],
        metavar="NAME=VALUES",
        help="sweep a parameter or h: START:STOP:COUNT or V1,V2,... (repeatable: a grid)",
    )
    e.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a parameter value (repeatable), as SPEC:NAME=VALUE; default the spec's",
    )
    e.add_argument("--method", help="integrator (default: spec's [run], or vi)")
    e.add_argument("--h", type=float, help="step size (RK45: output spacing); default [run] h")
    e.add_argument("--T", type=float, help="final time; default [run] T")
    e.add_argument("--rtol", type=float, default=1e-3, help="RK45 relative tolerance (1e-3)")
    e.add_argument("--atol", type=float, default=1e-6, help="RK45 absolute tolerance (1e-6)")
    e.add_argument(
        "--control", choices=("matlab", "hairer"), default="matlab", help="RK45 error control"
    )
    e.add_argument(
        "--max-steps",
        type=int,
        default=100000,
        metavar="N",
        help="RK45/DOP853 step budget per member: it stops after N attempted steps between two "
        "samples (0: no limit); default 100000",
    )
    e.add_argument("--every", type=int, default=1, metavar="K", help="store every K-th sample")
    e.add_argument("--seed", type=int, default=0, help="seed of the perturbations (default 0)")
    e.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, tcp://...")
    e.add_argument(
        "--workers", type=int, metavar="K", help="local worker processes (default: one per core)"
    )
    e.add_argument(
        "--timeout", type=float, default=10.0, help="seconds to reach the scheduler (10)"
    )
    e.add_argument(
        "--batch-size",
        type=int,
        metavar="B",
        help="members per task (default: by measurement, the first member's time)",
    )
    e.add_argument(
        "--tls-ca-file",
        metavar="PEM",
        help="TLS: the CA certificate that signs every participant's certificate; with "
        "--tls-cert every connection is encrypted and only holders of a certificate signed "
        "by this CA can join (the scheduler address is then tls://...)",
    )
    e.add_argument("--tls-cert", metavar="PEM", help="TLS: this participant's certificate (PEM)")
    e.add_argument(
        "--tls-key", metavar="PEM", help="TLS: the key of --tls-cert (omit if the file holds both)"
    )
    e.add_argument(
        "--dashboard",
        nargs="?",
        const=DASHBOARD,
        metavar="ADDRESS",
        help="serve the local cluster's Dask dashboard (its pages need bokeh; default address "
        f"{DASHBOARD}); off unless given",
    )
    e.add_argument("--out", default=DEFAULT_OUT, metavar="DIR", help=f"default {DEFAULT_OUT}")
    e.add_argument("--overwrite", action="store_true", help="replace DIR/ensemble.zarr")
    e.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    e.add_argument(
        "--bench",
        action="store_true",
        help="benchmark: the members serially vs on --workers (default 2) local workers, "
        "per-member overhead, client memory for 16 vs N members",
    )
    e.add_argument(
        "--chaos-band",
        action="store_true",
        help="the paper example SPEC's VI and RK45 runs as ensembles of --members (default "
        "64) perturbed members: min, median, max of mean |E - E0|",
    )


def command_line(args: argparse.Namespace) -> str:
    """The `s2gen ensemble` command line equivalent to parsed arguments."""
    parts = ["s2gen", "ensemble", args.spec]
    if args.members is not None:
        parts += ["--members", str(args.members)]
    for p in args.perturb:
        parts += ["--perturb", p]
    for s in args.sweep:
        parts += ["--sweep", s]
    for p in args.param:
        parts += ["--param", p]
    keys = ("method", "h", "T", "scheduler", "workers", "batch_size")
    for key in (*keys, "tls_ca_file", "tls_cert", "tls_key"):
        if getattr(args, key) is not None:
            parts += [f"--{key.replace('_', '-')}", str(getattr(args, key))]
    if args.dashboard is not None:
        parts += ["--dashboard", args.dashboard]
    defaults = {"rtol": 1e-3, "atol": 1e-6, "control": "matlab", "max_steps": 100000}
    for key, default in {**defaults, "every": 1, "seed": 0}.items():
        if getattr(args, key) != default:
            parts += [f"--{key.replace('_', '-')}", str(getattr(args, key))]
    parts += ["--out", str(args.out)]
    flags = ("overwrite", "no_figures", "bench", "chaos_band")
    return " ".join(parts + [f"--{f.replace('_', '-')}" for f in flags if getattr(args, f)])
