"""``python benchmarks/data_load.py``: how long a spec with 10^6 per-body data values takes
to load (`s2gen.spec.load_spec`: TOML parse, data conversion, the validated System), with the
values written inline in the TOML, in ``.npy`` files and in ``.txt`` files
(``c = { file = "c.npy" }``, `s2gen.spec.files`), and through `define_system` from NumPy
arrays already in memory.

Input: command-line options (``--bodies``, default 1000; ``--names``, the number of per-body
arrays, default 1000; ``--repeats``, default 5). Output: a table on stdout, one row per form:
the best and the median load time of `repeats` runs, the forms alternating run by run so that
all see the same load; for inline TOML also the time of `tomllib` alone. The header names the
CPU (from /proc/cpuinfo), Python, NumPy and the load average before and after.

Example:
    >>> parse_args(["--bodies", "10", "--names", "3"]).names
    3
    >>> sorted(write_forms(Path(tempfile.mkdtemp()), np.ones((2, 2))))
    ['.npy', '.txt', 'inline']
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from python_step import cpu_model

from s2gen.spec import define_system, load_spec

__all__ = ["main", "parse_args", "write_forms"]

HEAD = 'name = "big"\nbodies = {n}\n[parameters]\nm = 1.0\n[inertia]\ndiagonal = "m"\n'
TERM = '[potential]\n[[potential.body]]\nV = "d0*q[2] + d{last}*q[0]"\n[data]\n'


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line: --bodies, --names, --repeats."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bodies", type=int, default=1000)
    parser.add_argument("--names", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    return parser.parse_args(argv)


def write_forms(folder: Path, values: np.ndarray) -> dict[str, Path]:
    """The spec files of `values` (bodies x names) in each form, written under `folder`."""
    n, names = values.shape
    head = HEAD.format(n=n) + TERM.format(last=names - 1)
    inline = "".join(f"d{k} = {values[:, k].tolist()!r}\n" for k in range(names))
    specs = {"inline": head + inline}
    for suffix in (".npy", ".txt"):
        for k in range(names):
            path = folder / f"d{k}{suffix}"
            if suffix == ".npy":
                np.save(path, values[:, k])
            else:
                np.savetxt(path, values[:, k], fmt="%.17g")
        specs[suffix] = head + "".join(
            f'd{k} = {{ file = "d{k}{suffix}" }}\n' for k in range(names)
        )
    paths = {}
    for form, text in specs.items():
        paths[form] = folder / f"{form.strip('.')}.toml"
        paths[form].write_text(text)
    return paths


def _timed(run: Callable[[], object]) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def main(argv: Sequence[str] | None = None) -> None:
    """Write the forms, load each `repeats` times (alternating), print the table."""
    args = parse_args(argv)
    values = np.random.default_rng(1).normal(size=(args.bodies, args.names))
    arrays = {f"d{k}": values[:, k] for k in range(args.names)}
    print(f"# CPU: {cpu_model()}; Python {platform.python_version()}; NumPy {np.__version__}")
    print(f"# load average before: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        paths = write_forms(Path(tmp), values)
        text = paths["inline"].read_text()
        runs: dict[str, Callable[[], object]] = {
            "inline TOML": lambda: load_spec(paths["inline"]),
            "  tomllib alone": lambda: tomllib.loads(text),
            ".npy files": lambda: load_spec(paths[".npy"]),
            ".txt files": lambda: load_spec(paths[".txt"]),
            "define_system(arrays)": lambda: define_system(
                name="big",
                bodies=args.bodies,
                parameters={"m": 1.0},
                diagonal="m",
                data=arrays,
                body_terms=[{"V": f"d0*q[2] + d{args.names - 1}*q[0]"}],
            ),
        }
        times: dict[str, list[float]] = {form: [] for form in runs}
        for _ in range(args.repeats):
            for form, run in runs.items():
                times[form].append(_timed(run))
    print(f"# load average after: {os.getloadavg()[0]:.2f}")
    print(f"# {values.size} values: {args.bodies} bodies x {args.names} per-body arrays")
    print(f"{'form':<24}{'best s':>10}{'median s':>10}")
    for form, seconds in times.items():
        print(f"{form:<24}{min(seconds):>10.3f}{statistics.median(seconds):>10.3f}")


if __name__ == "__main__":
    sys.exit(main())
