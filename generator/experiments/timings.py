"""Measure the run times the README quotes, on this machine, and print them as a table.

Input: nothing (``--long`` adds the commands that take minutes; ``--out FILE`` also writes the
table as Markdown). Output: one row per command — the README's set-up commands' main parts
(``s2gen reproduce --quick`` and the test suite ``python -m pytest -q``) and the other commands
whose duration the README states — with its wall time from an empty build cache (what a fresh
install sees: derivation, emission and gcc included) and again with the cache that run left
(what every later run sees), and a line naming the machine.

Every command runs in a subprocess of this Python with a private, new cache folder
(``S2GEN_CACHE``) and writes its outputs to a temporary folder. The test suite runs in the
checkout this package was imported from (skipped, with a note, if there is none).

Run it as ``python -m s2gen.experiments.timings [--long] [--out timings.md]``.

Example:
    >>> [c.label for c in COMMANDS][:2]
    ['s2gen reproduce --quick', 'python -m pytest -q']
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["COMMANDS", "Command", "Timing", "checkout", "machine", "main", "measure", "table"]


@dataclass(frozen=True)
class Command:
    """A command whose duration the README states: its label (as the README writes it), its
    arguments after ``python -m`` (``{out}`` is replaced by a temporary folder), whether it
    needs the checkout (the test suite) and whether it takes minutes (run with --long)."""

    label: str
    args: tuple[str, ...]
    in_checkout: bool = False
    long: bool = False


#: The commands, in the README's order.
COMMANDS: tuple[Command, ...] = (
    Command("s2gen reproduce --quick", ("s2gen", "reproduce", "--quick", "--out", "{out}")),
    Command("python -m pytest -q", ("pytest", "-q", "-p", "no:cacheprovider"), in_checkout=True),
    Command("s2gen reproduce", ("s2gen", "reproduce", "--out", "{out}")),
    Command(
        "s2gen compare-angles double_pendulum --quick",
        ("s2gen", "compare-angles", "double_pendulum", "--quick", "--out", "{out}"),
    ),
    Command(
        "s2gen bench double_pendulum --quick",
        ("s2gen", "bench", "double_pendulum", "--quick", "--out", "{out}"),
    ),
    Command(
        "s2gen compare-angles double_pendulum",
        ("s2gen", "compare-angles", "double_pendulum", "--out", "{out}"),
        long=True,
    ),
    Command(
        "s2gen bench --long --stability --scaling",
        ("s2gen", "bench", "--long", "--stability", "--scaling", "--out", "{out}"),
        long=True,
    ),
)


@dataclass
class Timing:
    """Wall times of one command (None: not run), its exit status and a note."""

    command: Command
    cold: float | None = None
    warm: float | None = None
    status: int = 0
    note: str = ""


def checkout() -> Path | None:
    """The source checkout s2gen was imported from (it has tests/ and pyproject.toml), if any.

    Example:
        >>> checkout() is None or (checkout() / "pyproject.toml").is_file()
        True
    """
    import s2gen

    root = Path(s2gen.__file__).resolve().parent.parent
    return root if (root / "tests").is_dir() and (root / "pyproject.toml").is_file() else None


def machine() -> str:
    """One line naming this machine: CPU model, cores, memory, OS, Python and gcc.

    Example:
        >>> "Python" in machine()
        True
    """
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        memory = f"{os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES') / 2**30:.0f} GiB"
    except (AttributeError, OSError, ValueError):
        memory = "unknown memory"
    try:
        gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True, check=False)
        compiler = gcc.stdout.splitlines()[0] if gcc.stdout else "no gcc"
    except OSError:
        compiler = "no gcc"
    try:
        load = f"load average {os.getloadavg()[0]:.1f} (1 min) when printed"
    except OSError:
        load = "load average unknown"
    return (
        f"{cpu}, {os.cpu_count()} cores, {memory}, {platform.system()} {platform.release()}, "
        f"Python {platform.python_version()}, {compiler}; {load}"
    )


def _run_once(cmd: Command, cache: Path, cwd: Path) -> tuple[float, int, str]:
    """Wall time, exit status and last stderr line of one run with the given cache."""
    with tempfile.TemporaryDirectory(prefix="s2gen-timing-") as out:
        args = [a.replace("{out}", out) for a in cmd.args]
        env = {**os.environ, "S2GEN_CACHE": str(cache), "MPLBACKEND": "Agg"}
        start = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", *args],
            cwd=cwd,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            check=False,
        )
        wall = time.perf_counter() - start
    last = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ""
    return wall, proc.returncode, last


def measure(commands: Sequence[Command], warm: bool = True, log: object = print) -> list[Timing]:
    """Run each command from an empty cache, then (with `warm`) again with the cache it left.

    Example:
        >>> measure([], log=lambda s: None)
        []
    """
    say = log if callable(log) else print
    root = checkout()
    rows = []
    for cmd in commands:
        row = Timing(cmd)
        rows.append(row)
        if cmd.in_checkout and root is None:
            row.note = "no source checkout: not run"
            continue
        cwd = root if cmd.in_checkout and root is not None else Path.cwd()
        with tempfile.TemporaryDirectory(prefix="s2gen-cache-") as cache:
            say(f"{cmd.label}: empty cache ...")
            row.cold, row.status, last = _run_once(cmd, Path(cache), cwd)
            if warm and row.status == 0:
                say(f"{cmd.label}: warm cache ...")
                row.warm, row.status, last = _run_once(cmd, Path(cache), cwd)
        if row.status != 0:
            row.note = f"exit status {row.status}: {last}"
        say(f"{cmd.label}: {_seconds(row.cold)} s (empty cache), {_seconds(row.warm)} s (warm)")
    return rows


def _seconds(x: float | None) -> str:
    return "–" if x is None else f"{x:.1f}"


def table(rows: Sequence[Timing], host: str) -> str:
    """The Markdown table of measured times, with the machine they ran on.

    Example:
        >>> print(table([Timing(COMMANDS[0], 9.5, 3.25)], "a machine"))  # doctest: +ELLIPSIS
        | command | empty build cache (s) | warm build cache (s) | note |
        |---|---:|---:|---|
        | `s2gen reproduce --quick` | 9.5 | 3.2 |  |
        <BLANKLINE>
        Measured by `python -m s2gen.experiments.timings` on a machine.
    """
    lines = [
        "| command | empty build cache (s) | warm build cache (s) | note |",
        "|---|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| `{r.command.label}` | {_seconds(r.cold)} | {_seconds(r.warm)} | {r.note} |"
        )
    return "\n".join([*lines, "", f"Measured by `python -m s2gen.experiments.timings` on {host}."])


def main(argv: Sequence[str] | None = None) -> int:
    """Measure and print the table; 1 if a command failed."""
    p = argparse.ArgumentParser(prog="python -m s2gen.experiments.timings", description=__doc__)
    p.add_argument("--long", action="store_true", help="also the commands that take minutes")
    p.add_argument("--no-warm", action="store_true", help="only the empty-cache runs")
    p.add_argument("--only", nargs="*", default=None, help="labels of the commands to run")
    p.add_argument("--out", help="also write the table to this Markdown file")
    args = p.parse_args(argv)
    chosen = [c for c in COMMANDS if args.long or not c.long]
    if args.only:
        chosen = [c for c in COMMANDS if c.label in args.only]
    rows = measure(chosen, warm=not args.no_warm)
    text = table(rows, machine())
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    return 1 if any(r.status for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
