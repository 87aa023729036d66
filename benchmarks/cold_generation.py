"""``python benchmarks/cold_generation.py``: how long a system takes from its spec to a loaded
C library, with empty caches and with warm ones.

Input: command-line options (``--spec``, default ``molecular``; ``--seed``, the system that
fills the cache of derivations in the "after another system" state, default ``lj_cutoff``;
``--repeats``). Output: a table on stdout, one row per cache state:

- ``cold``: an empty cache folder (``S2GEN_CACHE``): every kernel derived, the C compiled;
- ``after <seed>``: a cache folder that only holds what ``s2gen generate <seed>`` left (the
  derivations of the kernels every system shares, and the seed's own): the first generation of
  a new system on a machine where s2gen has already run;
- ``warm``: the cache folder the cold run left (emitted files and library reused).

Each run is a fresh Python process (``python -c``) that runs ``s2gen generate SPEC --lang c``
(derive and emit: `s2gen.cli.main`) and then builds and loads the library (`s2gen.compile`).
The table gives, per state, the best and the median of `repeats` runs of: the process on the
wall clock (interpreter start and imports included), its CPU time (user and system, gcc's
included: on a shared machine the steadier figure, since it leaves out the time other jobs
hold the cores), the generate command in the process (its imports included), the build (gcc
and loading the library), and the derivation's stages as logged (``s2gen.derive``: equations
derived, passes done). The header names the CPU (from
/proc/cpuinfo), Python, gcc, the load average before and after, and whether s2gen's own modules
are read from Python's bytecode cache or compiled from source in every process (with
``PYTHONDONTWRITEBYTECODE`` set and no ``__pycache__`` beside them, the latter: about 0.2 s
of CPU per process, which an installed package does not pay).

``--against PYTHON`` runs the same processes with another interpreter too (e.g. another
checkout's virtual environment), alternating run by run so that both see the same load, and
prints its table and the ratios of the process CPU times, this one / the other.

Example:
    >>> parse_args(["--repeats", "3"]).repeats
    3
    >>> parse_args(["--against", "/usr/bin/python3"]).against
    '/usr/bin/python3'
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from python_step import cpu_model

__all__ = ["CHILD", "bytecode_state", "cpu_model", "main", "parse_args", "run_once"]

#: What one fresh process runs: generate, then build and load; it prints its times as JSON.
CHILD = r"""
import json, logging, sys, time
start = time.perf_counter()
stages = {}
class Stages(logging.Handler):
    def emit(self, record):
        stages[record.getMessage().split(": ", 1)[1]] = getattr(record, "since", 0.0)
log = logging.getLogger("s2gen.derive")
log.addHandler(Stages()); log.setLevel(logging.INFO)
from s2gen import cli
spec, out = sys.argv[1], sys.argv[2]
with open(out + ".log", "w") as sink:
    sys.stdout, saved = sink, sys.stdout
    status = cli.main(["generate", spec, "--lang", "c", "--out", out])
    sys.stdout = saved
generated = time.perf_counter()
import s2gen
s2gen.compile(s2gen.load(spec))
built = time.perf_counter()
print(json.dumps({"status": status, "generate": generated - start,
                  "build": built - generated, "stages": stages}))
"""


def _gcc() -> str:
    try:
        return subprocess.run(
            ["gcc", "--version"], capture_output=True, text=True, check=True
        ).stdout.splitlines()[0]
    except (OSError, subprocess.CalledProcessError, IndexError):
        return "gcc not found"


#: What `bytecode_state` runs in a fresh process of the interpreter it is given.
_BYTECODE = r"""
import importlib.util, os, sys
import s2gen
cached = os.path.exists(importlib.util.cache_from_source(s2gen.__file__))
print(("read from" if cached else "compiled from source") + " " + os.path.dirname(s2gen.__file__)
      + ("; bytecode not written" if sys.dont_write_bytecode else ""))
"""


def bytecode_state(python: str = sys.executable) -> str:
    """Whether `python`'s s2gen is read from Python's bytecode cache or compiled from source
    in every process, and where it lives.

    Example:
        >>> bytecode_state().split(" /")[0] in ("read from", "compiled from source")
        True
    """
    done = subprocess.run([python, "-c", _BYTECODE], capture_output=True, text=True, check=False)
    return done.stdout.strip() or f"unknown ({done.stderr.strip()[-200:]})"


def run_once(spec: str, cache: Path, out: Path, python: str = sys.executable) -> dict[str, object]:
    """One fresh process of `python` with ``S2GEN_CACHE=cache``: its times (seconds) as the
    child reports them, and ``wall``, the whole process on the parent's clock."""
    env = {**os.environ, "S2GEN_CACHE": str(cache)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [python, "-c", CHILD, spec, str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{spec}: the run failed:\n{done.stderr[-2000:]}")
    times: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    if times["status"] != 0:
        raise RuntimeError(f"{spec}: s2gen generate exited with {times['status']}")
    times["wall"] = wall
    times["cpu"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return times


def _state_runs(
    spec: str, seed: str, state: str, repeats: int, root: Path, pythons: Sequence[str]
) -> list[list[dict]]:
    """`repeats` runs of `spec` from one cache state (each from its own copy of it), per
    interpreter in `pythons`, alternating between them run by run."""
    runs: list[list[dict]] = [[] for _ in pythons]
    for k in range(repeats):
        for p, python in enumerate(pythons):
            cache = root / f"{state}-{k}-{p}"
            if state == "seeded":
                run_once(seed, cache, root / f"seed-{k}-{p}", python)
                for entry in cache.iterdir():
                    if entry.name != "derived":  # keep only the derivations
                        shutil.rmtree(entry) if entry.is_dir() else entry.unlink()
            elif state == "warm":
                run_once(spec, cache, root / f"prime-{k}-{p}", python)
            runs[p].append(run_once(spec, cache, root / f"out-{state}-{k}-{p}", python))
    return runs


def _row(label: str, runs: list[dict], stages: Sequence[str]) -> str:
    def cell(values: list[float]) -> str:
        return f"{min(values):6.2f} {statistics.median(values):6.2f}"

    keys = ("wall", "cpu", "generate", "build")
    cells = [cell([float(r[key]) for r in runs]) for key in keys]
    for stage in stages:
        values = [float(r["stages"][stage]) for r in runs if stage in r["stages"]]  # type: ignore[index]
        cells.append(cell(values) if values else f"{'-':>6} {'-':>6}")
    return f"| {label:<20} | " + " | ".join(cells) + " |"


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line's options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--spec", default="molecular", help="the system to generate (default molecular)")
    p.add_argument("--seed", default="lj_cutoff", help="the system run before (default lj_cutoff)")
    p.add_argument("--repeats", type=int, default=5, help="runs per cache state (default 5)")
    p.add_argument(
        "--against",
        metavar="PYTHON",
        help="another interpreter (e.g. another checkout's venv) run alternately; prints ratios",
    )
    return p.parse_args(argv)


def _table(spec: str, repeats: int, rows: list[tuple[str, list[dict]]]) -> None:
    stages = ("equations derived", "pass factor done", "pass workspace done")
    print(f"\n{spec}: seconds, best and median of {repeats} fresh processes")
    print(
        "(derivation stages: seconds since the derivation began, imports of the passes included)\n"
    )
    head = ["process", "process CPU", "generate", "build (gcc)", *stages]
    print("| cache state          | " + " | ".join(f"{h:^13}" for h in head) + " |")
    print("|" + "---|" * (len(head) + 1))
    for label, runs in rows:
        print(_row(label, runs, stages if label != "warm" else ()))


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table (and with ``--against``, the other interpreter's and the ratios);
    exit status 0."""
    args = parse_args(argv)
    pythons = [sys.executable] + ([args.against] if args.against else [])
    print(f"CPU: {cpu_model()} ({os.cpu_count()} logical cores)")
    print(f"Python {platform.python_version()}, {_gcc()}")
    for python in pythons:
        print(f"s2gen of {python}: {bytecode_state(python)}")
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory(prefix="s2gen-cold-") as tmp:
        root = Path(tmp)
        states = (("cold", "cold"), ("seeded", f"after {args.seed}"), ("warm", "warm"))
        rows = [
            (label, _state_runs(args.spec, args.seed, s, args.repeats, root, pythons))
            for s, label in states
        ]
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    for p, python in enumerate(pythons):
        if args.against:
            print(f"\n{python}:")
        _table(args.spec, args.repeats, [(label, runs[p]) for label, runs in rows])
    if args.against:
        print(f"\nprocess CPU, {sys.executable} / {args.against}: best, median")
        for label, runs in rows:
            mine, other = ([float(r["cpu"]) for r in rs] for rs in runs)
            best = min(mine) / min(other)
            median = statistics.median(mine) / statistics.median(other)
            print(f"  {label:<20} {best:5.2f} {median:5.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
