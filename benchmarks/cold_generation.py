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
/proc/cpuinfo), Python, gcc and the load average before and after.

Example:
    >>> parse_args(["--repeats", "3"]).repeats
    3
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

__all__ = ["CHILD", "cpu_model", "main", "parse_args", "run_once"]

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


def cpu_model() -> str:
    """The processor's name from /proc/cpuinfo, else what the platform says.

    Example:
        >>> isinstance(cpu_model(), str)
        True
    """
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _gcc() -> str:
    try:
        return subprocess.run(
            ["gcc", "--version"], capture_output=True, text=True, check=True
        ).stdout.splitlines()[0]
    except (OSError, subprocess.CalledProcessError, IndexError):
        return "gcc not found"


def run_once(spec: str, cache: Path, out: Path) -> dict[str, object]:
    """One fresh process with ``S2GEN_CACHE=cache``: its times (seconds) as the child reports
    them, and ``wall``, the whole process on the parent's clock."""
    env = {**os.environ, "S2GEN_CACHE": str(cache)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", CHILD, spec, str(out)],
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


def _state_runs(spec: str, seed: str, state: str, repeats: int, root: Path) -> list[dict]:
    """`repeats` runs of `spec` from one cache state (each from its own copy of it)."""
    runs = []
    for k in range(repeats):
        cache = root / f"{state}-{k}"
        if state == "seeded":
            run_once(seed, cache, root / f"seed-{k}")
            for entry in cache.iterdir():
                if entry.name != "derived":  # keep only the derivations
                    shutil.rmtree(entry) if entry.is_dir() else entry.unlink()
        elif state == "warm":
            run_once(spec, cache, root / f"prime-{k}")
        runs.append(run_once(spec, cache, root / f"out-{state}-{k}"))
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
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table; exit status 0."""
    args = parse_args(argv)
    print(f"CPU: {cpu_model()} ({os.cpu_count()} logical cores)")
    print(f"Python {platform.python_version()}, {_gcc()}")
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    stages = ("equations derived", "pass factor done", "pass workspace done")
    with tempfile.TemporaryDirectory(prefix="s2gen-cold-") as tmp:
        root = Path(tmp)
        states = (("cold", "cold"), ("seeded", f"after {args.seed}"), ("warm", "warm"))
        rows = [
            (label, _state_runs(args.spec, args.seed, s, args.repeats, root)) for s, label in states
        ]
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    print(f"\n{args.spec}: seconds, best and median of {args.repeats} fresh processes")
    print(
        "(derivation stages: seconds since the derivation began, imports of the passes included)\n"
    )
    head = ["process", "process CPU", "generate", "build (gcc)", *stages]
    print("| cache state          | " + " | ".join(f"{h:^13}" for h in head) + " |")
    print("|" + "---|" * (len(head) + 1))
    for label, runs in rows:
        print(_row(label, runs, stages if label != "warm" else ()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
