"""``python benchmarks/body_tables.py``: what a term's per-body data cost per step, read per
evaluation or combined once per call into the term's member table (`s2gen.passes.hoist`).

The system: `--bodies` particles on the sphere (a Fibonacci lattice), two species alternating,
each bonded to its `--neighbours` nearest (a listed pair term) by a Lennard-Jones potential
whose strength and size follow the Lorentz-Berthelot mixing rules, eps_ij = sqrt(e_i e_j) and
sigma_ij = (s_i + s_j) / 2. It is written twice: with per-body arrays (``[data]``, read as
``ei``, ``sj``, ... in the term) and with the mixed values precomputed here, one per listed
pair (the term's own data). Both spellings give the same trajectory; the per-pair one is what
a user would write by hand to save the mixing rule's square root and powers at every
evaluation.

Input: command-line options (``--bodies``, default 400; ``--neighbours``, default 6;
``--flags``; ``--steps``, default 2000; ``--repeats``, default 7). Output: a table on stdout,
one row per flag set (``portable``: -O2; ``native``: -O3 -march=native): the process's CPU
time per VI step with each spelling (the median of `repeats` runs of one ``integrate`` call,
the spellings alternating), their ratio, and the member-table slots per pair of each. The
header names the CPU (from /proc/cpuinfo) and the load average. Numbers only: no test times
them.

Example:
    >>> per_body, per_pair = systems(8, 2)
    >>> per_body.terms[0].data, sorted(d.name for d in per_pair.terms[0].data)
    ((), ['eps', 'sig'])
"""

from __future__ import annotations

import argparse
import os
import statistics

import numpy as np
from python_step import cpu_model
from structured_crossover import vi_cpu_per_step

from s2gen.passes import lower_system
from s2gen.runtime.c import CBackend
from s2gen.spec import define_system
from s2gen.system import System

__all__ = ["main", "parse_args", "systems"]

R2 = "dot(qi - qj, qi - qj)"
PER_BODY = f"4*sqrt(ei*ej)*(((si + sj)/2)**12/({R2})**6 - ((si + sj)/2)**6/({R2})**3)"
PER_PAIR = f"4*eps*(sig**12/({R2})**6 - sig**6/({R2})**3)"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bodies", type=int, default=400)
    ap.add_argument("--neighbours", type=int, default=6)
    ap.add_argument("--flags", nargs="+", default=["portable", "native"])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=7)
    return ap.parse_args(argv)


def _lattice(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5**0.5) * k
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def systems(n: int, neighbours: int) -> tuple[System, System]:
    """The benchmark's system with per-body data, and the same with per-pair data."""
    q0 = _lattice(n)
    d2 = ((q0[:, None, :] - q0[None, :, :]) ** 2).sum(-1)
    np.fill_diagonal(d2, np.inf)
    near = np.argsort(d2, axis=1)[:, :neighbours]
    pairs = sorted({(min(i, j), max(i, j)) for i in range(n) for j in near[i]})
    spacing = float(np.sqrt(np.median([d2[i, j] for i, j in pairs])))
    e = np.where(np.arange(n) % 2 == 0, 1.0, 0.6)
    s = np.where(np.arange(n) % 2 == 0, 1.0, 0.8) * spacing
    listed = [[i + 1, j + 1] for i, j in pairs]
    rng = np.random.default_rng(3)
    w0 = np.cross(q0, rng.normal(scale=0.2, size=(n, 3)))
    common = {"bodies": n, "diagonal": "m", "parameters": {"m": 1.0}}
    common |= {"initial_q": q0, "initial_omega": w0}
    per_body = define_system(
        name="bt_body",
        data={"e": e.tolist(), "s": s.tolist()},
        pair_terms=[{"V": PER_BODY, "pairs": listed}],
        **common,
    )
    mixed = {
        "eps": [float(np.sqrt(e[i] * e[j])) for i, j in pairs],
        "sig": [float((s[i] + s[j]) / 2) for i, j in pairs],
    }
    per_pair = define_system(
        name="bt_pair", pair_terms=[{"V": PER_PAIR, "pairs": listed, "data": mixed}], **common
    )
    return per_body, per_pair


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    print(f"cpu: {cpu_model()}; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    spellings = systems(args.bodies, args.neighbours)
    lowered = [lower_system(s).terms[0] for s in spellings]
    pairs, slots = lowered[0].loop.count, [t.table for t in lowered]
    print(
        f"{args.bodies} bodies, {pairs} listed pairs; table slots per pair: {slots[0]} / {slots[1]}"
    )
    print("| flags | per-body µs/step | per-pair µs/step | per-body/per-pair |")
    print("|---|---:|---:|---:|")
    for flags in args.flags:
        backs = [CBackend(s, opt=flags) for s in spellings]
        times: list[list[float]] = [[], []]
        for _ in range(args.repeats):
            for k, be in enumerate(backs):
                times[k].append(vi_cpu_per_step(be, args.steps, 1e-4))
        a, b = (statistics.median(t) for t in times)
        print(f"| {flags} | {a:.2f} | {b:.2f} | {a / b:.2f} |")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} after")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
