"""``python benchmarks/unseen.py``: emitted C against hand-written C on three new systems.

Input: command-line options (``--cases``, ``--flavours``, ``--launches``, ``--steps``,
``--json``, ``--keep``). Output: a table on stdout, one row per case and flavour: the median
time per step of the hand-written program and of the emitted C (each launch runs the case's
horizon `repeats` times and reports its own medians) and their ratio (emitted / hand), on the
wall clock and in CPU time, Newton iterations per step of both and the largest difference of
their final states; optionally the same as JSON. Exit status 1 when the final states differ by more than `AGREEMENT` (scaled by
the state's size): then the two programs do not integrate the same equations and their times
are not comparable.

Launches alternate (hand, emitted, hand, ...) within each case and flavour, so that the load
of a shared machine hits both alike; the table names the machine, its load average before and
after, and gcc's version. The wall clock is the usual measure; the process's CPU time
(CLOCK_PROCESS_CPUTIME_ID) leaves out the time other jobs hold the core, so on a busy machine
its ratio is the steadier one.

Example:
    >>> parse_args(["--launches", "3", "--cases", "chain"]).launches
    3
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from unseen_systems.cases import CASES
from unseen_systems.programs import COMMON, FLAVOURS, Result, build, run

__all__ = ["AGREEMENT", "Row", "agreement", "main", "parse_args"]

#: Largest accepted max |state_hand - state_emitted| / max(1, max |state|) at the horizon.
AGREEMENT = 1e-9


@dataclass(frozen=True)
class Row:
    """One case and flavour: medians over the launches."""

    case: str
    flavour: str
    steps: int
    hand_ns: float
    emitted_ns: float
    ratio: float
    hand_cpu_ns: float
    emitted_cpu_ns: float
    cpu_ratio: float
    hand_newton: float
    emitted_newton: float
    state_diff: float
    hand_energy_change: float
    emitted_energy_change: float


def agreement(hand: Result, emitted: Result) -> float:
    """max |difference| of the final states, relative to max(1, max |state|).

    Example:
        >>> a = Result(1.0, 1.0, 0.0, 0.0, np.array([1.0, 2.0]))
        >>> agreement(a, Result(1.0, 1.0, 0.0, 0.0, np.array([1.0, 2.5])))
        0.25
    """
    scale = max(1.0, float(np.max(np.abs(hand.state))))
    if hand.state.shape != emitted.state.shape:
        return float("inf")
    return float(np.max(np.abs(hand.state - emitted.state))) / scale


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(
        prog="python benchmarks/unseen.py",
        description="Per-step speed of the emitted C against hand-written C (same algorithm, "
        "same flags) on three systems the tests never see: yukawa (all pairs, exp and sqrt, "
        "per-body data; explicit VI), chain (coupled inertia; implicit VI) and mixture (two "
        "species with per-body data over the pairs within a cutoff; explicit VI).",
    )
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated (default: all)")
    ap.add_argument("--flavours", default=",".join(FLAVOURS), help="O2, O3n (default: both)")
    ap.add_argument("--launches", type=int, default=5, help="launches per program (default 5)")
    ap.add_argument(
        "--steps", type=int, default=0, help="steps per run (default: each case's horizon)"
    )
    ap.add_argument("--json", default="", help="also write the rows to this JSON file")
    ap.add_argument("--keep", default="", help="build in this folder and keep it")
    args = ap.parse_args(argv)
    for key, known in (("cases", CASES), ("flavours", FLAVOURS)):
        bad = [v for v in getattr(args, key).split(",") if v not in known]
        if bad:
            ap.error(f"--{key}: unknown {', '.join(bad)} (known: {', '.join(known)})")
    if args.launches < 1 or args.steps < 0:
        ap.error("--launches must be at least 1 and --steps not negative")
    return args


def _machine() -> str:
    gcc = subprocess.run(["gcc", "--version"], check=False, capture_output=True, text=True).stdout
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            cpu = next(
                (ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), cpu
            )
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores; {gcc.splitlines()[0] if gcc else 'gcc ?'}"


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "?"


def measure(
    case_name: str, flavour: str, programs: dict[str, Path], steps: int, launches: int, repeats: int
) -> Row:
    """Alternating launches of the two programs of one case and flavour."""
    hand: list[Result] = []
    emitted: list[Result] = []
    for _ in range(launches):
        hand.append(run(programs["hand"], steps, repeats))
        emitted.append(run(programs["emitted"], steps, repeats))
    diff = max(agreement(h, e) for h, e in zip(hand, emitted))
    h_ns = statistics.median(r.ns_per_step for r in hand)
    e_ns = statistics.median(r.ns_per_step for r in emitted)
    h_cpu = statistics.median(r.cpu_ns_per_step for r in hand)
    e_cpu = statistics.median(r.cpu_ns_per_step for r in emitted)
    return Row(
        case_name,
        flavour,
        steps,
        h_ns,
        e_ns,
        e_ns / h_ns,
        h_cpu,
        e_cpu,
        e_cpu / h_cpu,
        statistics.median(r.newton_per_step for r in hand),
        statistics.median(r.newton_per_step for r in emitted),
        diff,
        hand[0].energy_change,
        emitted[0].energy_change,
    )


def _print_row(row: Row) -> None:
    print(
        f"| {row.case} | {row.flavour} | {row.steps} | {row.hand_ns / 1e3:.1f} | "
        f"{row.emitted_ns / 1e3:.1f} | {row.ratio:.2f} | {row.hand_cpu_ns / 1e3:.1f} | "
        f"{row.emitted_cpu_ns / 1e3:.1f} | {row.cpu_ratio:.2f} | {row.hand_newton:.3f} | "
        f"{row.emitted_newton:.3f} | {row.state_diff:.1e} |",
        flush=True,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Build, check agreement, time and print the table; returns the exit status."""
    args = parse_args(argv)
    cases = [CASES[c] for c in args.cases.split(",")]
    flavours = tuple(args.flavours.split(","))
    print(f"machine: {_machine()}; load average {_load()} before")
    print(
        f"flags: gcc {' '.join(COMMON)} + "
        + " | ".join(f"{f}: {' '.join(FLAVOURS[f])}" for f in flavours)
    )
    for case in cases:
        print(f"  {case.name}: {case.what}")
    print(
        f"{args.launches} alternating launches per program; each launch reports the medians of "
        "its runs over the horizon (time per step on the wall clock and in CPU time, every "
        "state stored, energy = NULL); the table gives the medians over the launches\n"
    )
    print(
        "| system | flavour | steps | hand µs/step | emitted µs/step | emitted/hand | "
        "hand CPU µs/step | emitted CPU µs/step | emitted/hand (CPU) | "
        "Newton/step hand | Newton/step emitted | final states differ by |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|", flush=True)
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="s2gen-unseen-") as tmp:
        root = Path(args.keep) if args.keep else Path(tmp)
        for case in cases:
            programs = build(case, root / case.name, flavours)
            for flavour in flavours:
                row = measure(
                    case.name,
                    flavour,
                    {"hand": programs.hand[flavour], "emitted": programs.emitted[flavour]},
                    args.steps or case.steps,
                    args.launches,
                    case.repeats,
                )
                rows.append(row)
                _print_row(row)
    print(f"\nload average {_load()} after")
    if args.json:
        Path(args.json).write_text(json.dumps([asdict(r) for r in rows], indent=1) + "\n")
    worst = max(rows, key=lambda r: r.state_diff)
    if worst.state_diff > AGREEMENT:
        print(
            f"error: {worst.case} ({worst.flavour}): the final states differ by "
            f"{worst.state_diff:.2e} > {AGREEMENT:g}; the programs do not integrate the same "
            "equations, so their times are not comparable",
            file=sys.stderr,
        )
        return 1
    print(
        f"worst ratio emitted / hand-written: {max(r.ratio for r in rows):.2f} (wall clock), "
        f"{max(r.cpu_ratio for r in rows):.2f} (CPU time)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
