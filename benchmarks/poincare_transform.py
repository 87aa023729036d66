"""``python benchmarks/poincare_transform.py``: a symplectic time transformation against the
reversible one of ``vi*-adaptive`` and against DOP853, at equal energy error (issue 26).

The time-transformed methods of s2gen (``vi-adaptive`` ...) are reversible but not symplectic:
xi tracks the monitor R(q) reversibly and the VI runs in steps dt = eps / xi. The standard
symplectic alternative is the Poincare transformation: integrate

    H~(q, p) = G(q) (H(q, p) - E0),    G = 1 / R,

in a fictitious time s with a fixed step, so that dt/ds = G(q) on the level set H~ = 0. H~ is
not separable, so its symmetric, symplectic step is the generalized leapfrog (Stoermer-Verlet
for non-separable H) with the constraints |q_i| = 1 (RATTLE). For a diagonal M it costs one
gradient per step plus scalar iterations:

    p+ = p - (s/2) [grad G(q) (T(p+) + V(q) - E0) + G(q) grad V(q) + sum_i l_i q_i e_i]
    q' = q + (s/2) (G(q) + G(q')) M^-1 p+,  |q'_i| = 1
    p' = P(q') [p+ - (s/2) (grad G(q') (T(p+) + V(q') - E0) + G(q') grad V(q'))]

(P(q') projects each body's momentum on the tangent plane). The unknowns are the per-body
multipliers l_i (closed form given the others), the scalar T(p+) and the scalar sigma =
(s/2)(G(q) + G(q')); they are found by fixed-point iteration to round-off, which costs monitor
evaluations only. The step is composed to order 4, 6 and 8 with the same compositions as the
VI (`s2gen.methods`), with step s = eps, the same meaning as the ``vi*-adaptive`` methods' h.

This program runs it in NumPy (the potential's value and gradient from the emitted C through
`Model.energy` / `Model.gradient`, the monitor from `s2gen.monitor`), and the emitted C's
``vi{4,6,8}-adaptive`` and DOP853 on the same system and horizon. It prints per run the
gradient evaluations and the largest relative energy error max |E - E0| / |E0| (the Poincare
runs measured after every step, the others on their output grid of step h), then per target
error the cheapest run of each kind that keeps it. Wall times are not compared (the Poincare
step is Python): the comparison is in gradient evaluations, the issue's measure.

Example:
    >>> parse_args(["--T", "1", "--orders", "4"]).orders
    [4]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp
from python_step import cpu_model

from s2gen import Model
from s2gen.methods import KAHAN_LI8, PLAIN, TRIPLE_JUMP, YOSHIDA6
from s2gen.monitor import C, monitor
from s2gen.runtime.options import Options
from s2gen.systems import builtin

__all__ = ["Poincare", "main", "parse_args"]

COMPOSITIONS = {2: PLAIN, 4: TRIPLE_JUMP, 6: YOSHIDA6, 8: KAHAN_LI8}
TARGETS = (1e-4, 1e-6, 1e-8)


@dataclass
class Run:
    """One run: its label, gradient evaluations and largest relative energy error."""

    label: str
    evals: int
    max_rel: float


class Poincare:
    """The Poincare-transformed generalized RATTLE on a closed system with a diagonal M and a
    pair monitor (`s2gen.monitor`), in NumPy.

    Example:
        >>> p = Poincare("encounter_cluster")
        >>> run = p.run(4, 0.1, 0.05)
        >>> run.evals > 0 and run.max_rel < 1e-3
        True
    """

    def __init__(self, name: str) -> None:
        self.system = builtin(name)
        self.model = Model(self.system)
        n = self.system.n
        self.q0 = np.array(self.system.q0, dtype=float)
        self.w0 = np.array(self.system.omega0, dtype=float)
        mon = monitor(self.system)
        if mon.given is not None or not mon.rates:
            raise ValueError(f"{name}: needs the pair monitor")
        values = {s: self.system.parameters[str(s)] for s in mon.parameters}
        self.rates = [
            (
                sp.lambdify(C, r.rate.subs(values), "numpy"),
                sp.lambdify(C, r.slope.subs(values), "numpy"),
                np.array(r.members, dtype=int).reshape(-1, 2),
            )
            for r in mon.rates
        ]
        # masses of a diagonal M: twice the kinetic energy of a unit angular velocity
        zero = np.zeros((n, 3))
        v0 = self.model.energy(self.q0, zero)
        self.m = np.empty(n)
        for i in range(n):
            w = zero.copy()
            w[i] = np.cross(self.q0[i], [1.0, 0.0, 0.0] if abs(self.q0[i][0]) < 0.9 else [0, 1, 0])
            w[i] /= np.linalg.norm(w[i])
            self.m[i] = 2.0 * (self.model.energy(self.q0, w) - v0)
        self.evals = 0

    def _G(self, x: np.ndarray, grad: bool) -> tuple[float, np.ndarray | None]:
        R, dR = 0.0, np.zeros_like(x) if grad else None
        for rate, slope, ij in self.rates:
            c = np.einsum("ij,ij->i", x[ij[:, 0]], x[ij[:, 1]])
            R += float(np.sum(rate(c) * np.ones_like(c)))
            if dR is not None:
                d = slope(c) * np.ones_like(c)
                np.add.at(dR, ij[:, 0], d[:, None] * x[ij[:, 1]])
                np.add.at(dR, ij[:, 1], d[:, None] * x[ij[:, 0]])
        return 1.0 / R, None if dR is None else -dR / R**2

    def _V(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        self.evals += 1
        return self.model.energy(x, np.zeros_like(x)), self.model.gradient(x)

    def _T(self, p: np.ndarray) -> float:
        return float(0.5 * np.sum(p * p / self.m[:, None]))

    def _step(self, x: np.ndarray, p: np.ndarray, s: float, e0: float, at: dict) -> tuple:
        V, gV, G, gG = at["V"], at["gV"], at["G"], at["gG"]
        A = p - 0.5 * s * G * gV
        B = -0.5 * s * gG
        tau, sig = self._T(p), s * G
        m = self.m[:, None]
        for _ in range(100):
            u = A + B * (tau + V - e0)
            beta = sig / m
            xu = np.einsum("ij,ij->i", x, u)[:, None]
            uu = np.einsum("ij,ij->i", u, u)[:, None]
            alpha = -beta * xu + np.sqrt(1.0 - beta * beta * (uu - xu * xu))
            x1 = alpha * x + beta * u
            ph = u - (1.0 - alpha) * m / sig * x
            tau1, sig1 = self._T(ph), 0.5 * s * (G + self._G(x1, False)[0])
            done = abs(tau1 - tau) <= 4e-16 * abs(tau1) and abs(sig1 - sig) <= 4e-16 * abs(sig1)
            tau, sig = tau1, sig1
            if done:
                break
        V1, gV1 = self._V(x1)
        G1, gG1 = self._G(x1, True)
        F = ph - 0.5 * s * (gG1 * (tau + V1 - e0) + G1 * gV1)
        p1 = F - np.einsum("ij,ij->i", F, x1)[:, None] * x1
        at.update(V=V1, gV=gV1, G=G1, gG=gG1)
        return x1, p1, sig

    def run(self, order: int, eps: float, T: float) -> Run:
        """The order-`order` composition at fictitious step eps up to time T."""
        x = self.q0 / np.linalg.norm(self.q0, axis=1)[:, None]
        p = self.m[:, None] * np.cross(self.w0, x)
        self.evals = 0
        V, gV = self._V(x)
        G, gG = self._G(x, True)
        at = {"V": V, "gV": gV, "G": G, "gG": gG}
        e0 = self._T(p) + V
        t, worst = 0.0, 0.0
        fractions = COMPOSITIONS[order].fractions
        while t < T:
            for f in fractions:
                x, p, dt = self._step(x, p, f * eps, e0, at)
                t += dt
            worst = max(worst, abs(self._T(p) + at["V"] - e0) / abs(e0))
        return Run(f"poincare{order} eps={eps:.3g}", self.evals, worst)


def _emitted(model: Model, method: str, setting: float, T: float, h: float) -> Run:
    if method == "dop853":
        r = model.integrate("dop853", h=h, T=T, options=Options(rtol=setting, atol=setting))
        label = f"dop853 tol={setting:.1e}"
    else:
        r = model.integrate(method, h=setting, T=T)
        label = f"{method} eps={setting:.3g}"
    e = np.asarray(r.energy)
    return Run(label, int(r.stats["gradient_evals"]), float(np.max(np.abs(e - e[0]) / abs(e[0]))))


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--system", default="encounter_cluster")
    ap.add_argument("--T", type=float, default=10.0, help="horizon (default 10)")
    ap.add_argument("--orders", type=int, nargs="+", default=[4, 6, 8])
    ap.add_argument("--eps", type=float, nargs="+", default=[0.1, 0.05])
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11])
    return ap.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> None:
    """Run and print the comparison."""
    args = parse_args(argv)
    print(f"CPU: {cpu_model()}; load {os.getloadavg()[0]:.1f}; {args.system}, T = {args.T}")
    pc = Poincare(args.system)
    h = pc.system.run.h or 0.01
    runs: dict[str, list[Run]] = {"poincare": [], "adaptive": [], "dop853": []}
    for order in args.orders:
        for eps in args.eps:
            t0 = time.perf_counter()
            runs["poincare"].append(pc.run(order, eps, args.T))
            dt = time.perf_counter() - t0
            runs["adaptive"].append(_emitted(pc.model, f"vi{order}-adaptive", eps, args.T, h))
            for r in (runs["poincare"][-1], runs["adaptive"][-1]):
                print(f"{r.label:28s} {r.evals:>10,d} evals  max rel dE {r.max_rel:.2e}")
            print(f"{'':28s} (the Poincare run: {dt:.1f} s in Python)")
    for tol in args.tols:
        r = _emitted(pc.model, "dop853", tol, args.T, h)
        runs["dop853"].append(r)
        print(f"{r.label:28s} {r.evals:>10,d} evals  max rel dE {r.max_rel:.2e}")
    print("\ncheapest run keeping max rel dE <= target (gradient evaluations):")
    print(f"{'target':>8s}  " + "  ".join(f"{k:>34s}" for k in runs))
    for target in TARGETS:
        cells = []
        for kind_runs in runs.values():
            ok = [r for r in kind_runs if r.max_rel <= target]
            best = min(ok, key=lambda r: r.evals) if ok else None
            cells.append(f"{best.label} {best.evals:,d}" if best else "none")
        print(f"{target:8.0e}  " + "  ".join(f"{c:>34s}" for c in cells))
    print(f"load at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
