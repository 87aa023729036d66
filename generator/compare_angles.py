"""The (S^2)^n form against the classical spherical-angle form: numbers and pictures.

Input: a `System` (SPEC) and `Settings`. Output: a `Comparison` (every number), written as
``compare_angles.md`` (Markdown tables), ``compare_angles.json`` and PNG figures to a folder.

What is measured, for both forms generated from the same (M, V):
- cost: derivation + cse time (each derivation in a fresh subprocess under a time budget, so a
  blow-up is reported as "> budget" instead of hanging), operations after cse (the lowered
  kernels' op counts: the right-hand-side kernels once, and as evaluated per call), emitted C
  size, gcc -O2 time, time per right-hand-side evaluation (emitted C, best of k);
- accuracy: RK45 at the same tolerances and RK4 at the same h, against a converged S^2 reference
  (S^2 RK45 at rtol 1e-12); every metric on (q, omega) samples, the angle form's mapped back, the
  energy by the S^2 module's energy function (`metrics.summary`);
- near a pole: the body nearest a pole at t = 0 is turned onto it, moved back along its motion
  by `alpha` and tilted by beta (`tilted_state`); the tilt beta* whose trajectory passes
  through the pole is found by bisection (`through_tilt`), and beta* + delta for delta in
  `tilts` pass about delta from it: accuracy, accepted/rejected RK45 steps over time, failures;
- scaling: chains of n = 1..`chain_max` spherical pendula (`chain_system`).

The S^2 module reports only total step counts, so its steps over time are measured by runs to
successive horizons with a fixed hmax (the same step sequence up to the last, clipped step);
the angle module writes its cumulative counts at every sample.

Example:
    >>> from s2gen.systems import builtin
    >>> c = compare(builtin("double_pendulum"), Settings.quick(), "/tmp/ca")  # doctest: +SKIP
    >>> c.accuracy[1].status  # doctest: +SKIP
    'PoleError'
"""

from __future__ import annotations

import argparse
import ctypes
import json
import multiprocessing
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import metrics
from .angles import (
    AngleIntegrationError,
    PoleError,
    derive_angles,
    lower_angles,
    print_angles,
    simulate_angles,
)
from .build import DEFAULT_FLAGS, compile_shared, compiler, header_macro
from .continuous import continuous_kernels
from .ir import Kernel, Module
from .lowering import lower, lower_system
from .printing import print_module
from .render import render, render_angles
from .runtime import IntegrationError, Options, get_backend, simulate
from .spec import define_system
from .structure import coupling_pairs, system_kernels, term_kernels
from .system import System

__all__ = [
    "FORMS",
    "Comparison",
    "Cost",
    "Run",
    "Settings",
    "add_parser",
    "chain_system",
    "compare",
    "costs",
    "run",
    "tilted_state",
]

#: The forms compared: the S^2 form, the angle form as derived, the angle form simplified.
FORMS = ("s2", "angles", "angles-simplified")
_LABELS = {"s2": "S² form", "angles": "angle form", "angles-simplified": "angle form, simplified"}
_REFERENCE_RTOL, _REFERENCE_ATOL = 1e-12, 1e-14
#: Half width of the time window around a pole pass shown in detail (figures, step counts).
ZOOM = 0.15


@dataclass(frozen=True)
class Settings:
    """What to run. `budget`: seconds per derivation; `windows`: S^2 step-count resolution."""

    T: float = 10.0
    h: float = 0.01
    rtol: float = 1e-6
    atol: float = 1e-9
    control: str = "matlab"
    budget: float = 120.0
    tilts: tuple[float, ...] = (1e-1, 1e-2, 1e-3, 1e-4)
    alpha: float = 0.5
    chain_max: int = 10
    repeats: int = 5
    windows: int = 50

    @staticmethod
    def quick() -> Settings:
        """Short runs for a smoke test (about a minute).

        Example:
            >>> Settings.quick().chain_max
            3
        """
        return Settings(T=2.0, budget=30.0, tilts=(1e-2, 1e-4), chain_max=3, repeats=3, windows=10)

    def options(self) -> Options:
        return Options(rtol=self.rtol, atol=self.atol, control=self.control)


# ------------------------------------------------------------------------------- derivation cost
def _rhs_ops_s2(module: Module) -> tuple[int, int, int]:
    """(ops before cse, after cse, after cse as evaluated per call) of the S^2 vector field."""
    named = {k.name: k for k in module.system_kernels + module.body_kernels}
    uses: list[tuple[Kernel, int]] = [(named["inertia"], 1)]
    if "gradient" in named:
        uses.append((named["gradient"], 1))
    uses += [(t.gradient, t.count) for t in module.terms]
    npairs = len(module.pairs)
    if module.coupled:
        uses += [(named["rhs_body"], module.n), (named["rhs_pair"], npairs)]
        uses.append((named["a_pair"], npairs))
    else:
        uses.append((named["rhs_diag"], module.n))
    before = sum(k.ops_before for k, _ in uses)
    return before, sum(k.ops_after for k, _ in uses), sum(k.ops_after * c for k, c in uses)


def _s2_field_seconds(system: System) -> float:
    """Derivation + cse time of the S^2 vector field alone (continuous and system kernels)."""
    start = time.perf_counter()
    coupled = bool(coupling_pairs(system))
    defs = continuous_kernels(coupled) + system_kernels(system)
    defs += [k for i, t in enumerate(system.terms) for k in term_kernels(system, i, t)]
    for k in defs:
        lower(k)
    return time.perf_counter() - start


def _derive(system: System, form: str) -> dict[str, Any]:
    """Derive, lower and emit one form in this process; timings, op counts and C files.

    "seconds" is the vector field's derivation + cse; "module_seconds" that of every kernel
    of the emitted module (for S^2 also the variational integrators' generic kernels).
    """
    if form == "s2":
        field = _s2_field_seconds(system)
        start = time.perf_counter()
        module = lower_system(system)
        whole = time.perf_counter() - start
        files = render(print_module(module), "c")
        before, after, evaluated = _rhs_ops_s2(module)
        dim = 3 * system.n if module.coupled else 0
        solve = dim**3 // 3
    else:
        start = time.perf_counter()
        angles = lower_angles(derive_angles(system, simplify=form == "angles-simplified"))
        field = whole = time.perf_counter() - start
        files = render_angles(print_angles(angles), "c")
        before = angles.system_kernels[0].ops_before
        after = evaluated = angles.system_kernels[0].ops_after
        solve = 2 * (2 * system.n) ** 3 // 3
    return {
        "seconds": field,
        "module_seconds": whole,
        "ops_before": before,
        "ops": after,
        "ops_evaluated": evaluated,
        "solve_flops": solve,
        "files": files,
    }


def _derive_job(system: System, form: str, conn: Any) -> None:
    """Subprocess entry: derive one form and send the result (or the error) back."""
    try:
        conn.send(_derive(system, form))
    except Exception as exc:  # noqa: BLE001 - any failure is reported to the parent
        conn.send({"error": f"{type(exc).__name__}: {exc}"})
    conn.close()


def derive_with_budget(system: System, form: str, budget: float) -> dict[str, Any] | None:
    """`_derive` in a fresh subprocess (cold caches); None if it takes longer than `budget` s.

    Example:
        >>> from s2gen.systems import builtin
        >>> derive_with_budget(builtin("double_pendulum"), "angles", 60)["ops"]  # doctest: +SKIP
        386
    """
    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_derive_job, args=(system, form, child), daemon=True)
    proc.start()
    child.close()
    result: dict[str, Any] | None = None
    if parent.poll(budget):
        result = parent.recv()
    proc.join(timeout=None if result is not None else 0)
    if proc.is_alive():
        proc.terminate()
        proc.join()
    return result


# ----------------------------------------------------------------------------- compile and time
_BENCH = """\
/* Timing harness of s2gen compare-angles: evaluates the vector field `reps` times. */
#include "{header}"

int {prefix}_bench(const double *p, const double *a, const double *b, double *c, double *d,
        double *work, long reps)
{{
    long k;
    int status = 0;
    (void)d;
    for (k = 0; k < reps; ++k) {{
        status |= {call};
    }}
    return status;
}}
"""


def gcc_seconds(files: dict[str, str]) -> float:
    """Wall time of one uncached `gcc -O2 -shared` of the emitted C (build.DEFAULT_FLAGS)."""
    cc, _ = compiler()
    with tempfile.TemporaryDirectory(prefix="s2gen-gcc-") as tmp:
        for name, text in files.items():
            (Path(tmp) / name).write_text(text)
        sources = [str(Path(tmp) / n) for n in sorted(files) if n.endswith(".c")]
        start = time.perf_counter()
        subprocess.run(
            [cc, *DEFAULT_FLAGS, "-o", str(Path(tmp) / "lib.so"), *sources, "-lm"], check=True
        )
        return time.perf_counter() - start


def generic_angles(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Angles and rates (x, xd) of a state with every body well away from the poles.

    Example:
        >>> generic_angles(1)
        (array([0.4, 0.3]), array([ 0.5, -0.3]))
    """
    i = np.arange(n)
    x = np.stack([0.4 + 0.1 * (i % 8), 0.3 + 0.7 * i], axis=1).ravel()
    xd = np.stack([0.5 - 0.05 * i, -0.3 + 0.1 * i], axis=1).ravel()
    return x, xd


def generic_state(n: int) -> tuple[np.ndarray, np.ndarray]:
    """`generic_angles` as (q, omega = q x qdot), shape (n, 3) each (timing, chain states).

    Example:
        >>> q, w = generic_state(2)
        >>> bool(np.all(np.abs(q[:, 2]) < 0.95)), float(np.max(np.abs(np.sum(q * w, 1)))) < 1e-15
        (True, True)
    """
    x, xd = generic_angles(n)
    th, ph, thd, phd = x[0::2], x[1::2], xd[0::2], xd[1::2]
    st, ct, sp_, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    q = np.stack([st * cp, st * sp_, ct], axis=1)
    qdot = thd[:, None] * np.stack([ct * cp, ct * sp_, -st], axis=1)
    qdot += (st * phd)[:, None] * np.stack([-sp_, cp, np.zeros(n)], axis=1)
    return q, np.cross(q, qdot)


class RhsTimer:
    """Times the emitted C vector field of one form at `generic_angles` (the same state for
    both forms): each call runs one loop calibrated to about 20 ms (a harness compiled with the
    module) and returns ns per evaluation."""

    def __init__(self, system: System, form: str, files: dict[str, str]) -> None:
        header = next(name for name in files if name.endswith(".h"))
        prefix = header[:-2]
        if form == "s2":
            a, b = (v.ravel() for v in generic_state(system.n))
            call = f"{prefix}_rhs(p, a, b, c, d, work)"
        else:
            a, b = generic_angles(system.n)
            call = f"{prefix}_rhs(p, a, b, c, work)"
        bench = _BENCH.format(header=header, prefix=prefix, call=call)
        self.lib = ctypes.CDLL(str(compile_shared({**files, "bench.c": bench}).path))
        self.fn = getattr(self.lib, f"{prefix}_bench")
        self.fn.restype = ctypes.c_int
        self.arrays = [np.array(system.parameter_values, float), a, b]
        self.arrays += [
            np.zeros(a.size),
            np.zeros(a.size),
            np.zeros(header_macro(files[header], "WORK_SIZE")),
        ]
        self.args = [ctypes.c_void_p(x.ctypes.data) for x in self.arrays]
        self.name = prefix
        self.reps = max(1, int(0.02 / max(self._loop(1000) / 1000, 1e-9)))

    def _loop(self, reps: int) -> float:
        start = time.perf_counter()
        if self.fn(*self.args, ctypes.c_long(reps)) != 0:
            raise RuntimeError(f"{self.name}_rhs failed at the timing state")
        return time.perf_counter() - start

    def __call__(self) -> float:
        return 1e9 * self._loop(self.reps) / self.reps


@dataclass(frozen=True)
class Cost:
    """The cost of one form of one system; `status` is "ok", "> budget" or an error."""

    form: str
    n: int
    status: str
    seconds: float = float("nan")
    module_seconds: float = float("nan")
    ops_before: int = 0
    ops: int = 0
    ops_evaluated: int = 0
    solve_flops: int = 0
    c_bytes: int = 0
    c_lines: int = 0
    gcc_seconds: float = float("nan")
    rhs_ns: float = float("nan")


def _build(system: System, form: str, budget: float) -> tuple[Cost, RhsTimer | None]:
    """Derive (subprocess, budget) and compile one form: its cost so far and its timer."""
    got = derive_with_budget(system, form, budget)
    if got is None:
        return Cost(form, system.n, f"> {budget:g} s"), None
    if "error" in got:
        return Cost(form, system.n, got["error"]), None
    files: dict[str, str] = got["files"]
    c = Cost(
        form=form,
        n=system.n,
        status="ok",
        seconds=got["seconds"],
        module_seconds=got["module_seconds"],
        ops_before=got["ops_before"],
        ops=got["ops"],
        ops_evaluated=got["ops_evaluated"],
        solve_flops=got["solve_flops"],
        c_bytes=sum(len(t.encode()) for t in files.values()),
        c_lines=sum(t.count("\n") for t in files.values()),
        gcc_seconds=gcc_seconds(files),
    )
    return c, RhsTimer(system, form, files)


def costs(
    system: System,
    forms: Sequence[str],
    budget: float,
    repeats: int,
    skip: dict[str, str] | None = None,
) -> list[Cost]:
    """Derive and compile each form, then time their vector fields side by side (the forms
    interleaved, best of `repeats`). Forms in `skip` are not tried (status given).

    Example:
        >>> from s2gen.systems import builtin
        >>> dp = builtin("double_pendulum")
        >>> [c.status for c in costs(dp, FORMS[:2], 60, 3)]  # doctest: +SKIP
        ['ok', 'ok']
    """
    skip = skip or {}
    built = [
        (Cost(f, system.n, skip[f]), None) if f in skip else _build(system, f, budget)
        for f in forms
    ]
    best = {c.form: float("inf") for c, timer in built if timer is not None}
    for _ in range(max(1, repeats)):
        for c, timer in built:
            if timer is not None:
                best[c.form] = min(best[c.form], timer())
    return [replace(c, rhs_ns=best[c.form]) if c.form in best else c for c, _ in built]


# --------------------------------------------------------------------------------- trajectories
@dataclass
class Run:
    """One integration of one form, measured against the reference on the output grid."""

    form: str
    method: str
    status: str
    message: str = ""
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    error: np.ndarray = field(default_factory=lambda: np.zeros(0))  # max_i |q_i - q_i,ref|
    energy_error: np.ndarray = field(default_factory=lambda: np.zeros(0))  # |E - E0|
    counts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # t, accepted, rejected
    summary: dict[str, float] = field(default_factory=dict)
    steps: int = 0
    rejected: int = 0
    evals: int = 0
    wall: float = float("nan")

    def max_error(self) -> float:
        return float(np.max(self.error)) if self.error.size else float("nan")

    def brief(self) -> dict[str, Any]:
        """The scalar results (for the JSON file)."""
        keys = ("form", "method", "status", "message", "steps", "rejected", "evals", "wall")
        out = {k: getattr(self, k) for k in keys}
        reached = float(self.t[-1]) if self.t.size else 0.0
        return {**out, "max_error": self.max_error(), "t_reached": reached, **self.summary}


def _energies(system: System, q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Energy of (q, omega) samples by the S^2 module's energy function (same for both forms)."""
    be = get_backend(system, "c")
    p = np.array(system.parameter_values, float)
    return np.array([be.energy(q[k], w[k], p) for k in range(len(q))])


def _measure(r: Run, system: System, ref: np.ndarray, q: np.ndarray, w: np.ndarray) -> Run:
    k = len(q)
    r.error = np.max(np.linalg.norm(q - ref[:k], axis=2), axis=1)
    en = _energies(system, q, w)
    r.energy_error = np.abs(en - en[0])
    r.summary = metrics.summary(q, en) if k else {}
    return r


def _run_s2(
    system: System, method: str, s: Settings, state: tuple[np.ndarray, np.ndarray], ref: np.ndarray
) -> Run:
    opts = s.options()
    try:
        tr = simulate(system, method, "c", h=s.h, T=s.T, options=opts, q0=state[0], omega0=state[1])
        status, message = "ok", ""
    except IntegrationError as exc:
        tr, status, message = exc.partial, "failed", str(exc)
    r = Run("s2", method, status, message, t=tr.t, wall=tr.wall_time)
    r.steps, r.rejected = tr.stats.get("steps", 0), tr.stats.get("rejected", 0)
    r.evals = tr.stats.get("gradient_evals", 0)
    return _measure(r, system, ref, tr.q, tr.omega)


def _run_angles(
    system: System, method: str, s: Settings, state: tuple[np.ndarray, np.ndarray], ref: np.ndarray
) -> Run:
    opts = s.options()
    try:
        tr = simulate_angles(system, method, "c", s.h, s.T, opts, state[0], state[1])
        status, message = "ok", ""
    except PoleError as exc:
        return Run("angles", method, "PoleError", str(exc), wall=0.0)
    except AngleIntegrationError as exc:
        tr, status, message = exc.partial, "failed", str(exc)
    r = Run("angles", method, status, message, t=tr.t, wall=tr.wall_time)
    r.steps, r.rejected = int(tr.stats["steps"]), int(tr.stats["rejected"])
    r.evals = int(tr.stats["rhs_evals"])
    r.counts = np.column_stack([tr.t, tr.counts])
    return _measure(r, system, ref, tr.q, tr.omega)


def _s2_counts(
    system: System, s: Settings, state: tuple[np.ndarray, np.ndarray], around: float | None
) -> np.ndarray:
    """(t, accepted, rejected) of the S^2 RK45 at `windows` horizons (and at every sample within
    `ZOOM` of the time `around`), each a run from t = 0 with hmax fixed at T/10."""
    nsteps = round(s.T / s.h)
    ks = {max(1, round(nsteps * j / s.windows)) for j in range(1, s.windows + 1)}
    if around is not None:
        lo, hi = round((around - ZOOM) / s.h), round((around + ZOOM) / s.h)
        ks |= set(range(max(1, lo), min(nsteps, hi) + 1))
    rows = [(0.0, 0, 0)]
    opts = replace(s.options(), hmax=0.1 * s.T)
    for k in sorted(ks):
        try:
            tr = simulate(
                system, "rk45", "c", h=s.h, T=k * s.h, options=opts, q0=state[0], omega0=state[1]
            )
        except IntegrationError:
            break
        rows.append((k * s.h, tr.stats["steps"], tr.stats["rejected"]))
    return np.array(rows, dtype=float)


def reference(system: System, s: Settings, state: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """q on the output grid from the S^2 RK45 at rtol 1e-12 (the converged reference)."""
    opts = Options(rtol=_REFERENCE_RTOL, atol=_REFERENCE_ATOL, control=s.control)
    tr = simulate(system, "rk45", "c", h=s.h, T=s.T, options=opts, q0=state[0], omega0=state[1])
    return tr.q


def accuracy(
    system: System,
    s: Settings,
    state: tuple[np.ndarray, np.ndarray],
    ref: np.ndarray,
    around: float | None = None,
) -> list[Run]:
    """Both forms with RK45 and RK4 against `ref`; the S^2 RK45 step counts over time (finely
    resolved near the time `around`) attached to its run."""
    runs = []
    for method in ("rk45", "rk4"):
        runs.append(_run_s2(system, method, s, state, ref))
        runs.append(_run_angles(system, method, s, state, ref))
    runs[0].counts = _s2_counts(system, s, state, around)
    return runs


# ---------------------------------------------------------------------------------- near a pole
def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about the unit vector `axis` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def pole_body(q: np.ndarray) -> int:
    """The body (0-based) whose q_i is nearest a pole +-e3."""
    return int(np.argmin(np.hypot(q[:, 0], q[:, 1])))


def tilted_state(
    q0: np.ndarray, w0: np.ndarray, body: int, alpha: float, beta: float
) -> tuple[np.ndarray, np.ndarray]:
    """Body `body` turned onto its nearest pole, moved back along its great circle by `alpha`
    and tilted by `beta` about its direction of motion there: it then passes about `beta` from
    the pole (exactly, for a free body) after an arc `alpha`.

    Example:
        >>> q, w = tilted_state(np.array([[0, 0, 1.0]]), np.array([[0, 1.0, 0]]), 0, 0.5, 1e-3)
        >>> np.round(q, 4).tolist(), float(np.round(np.dot(q[0], w[0]), 15))
        ([[-0.4794, -0.0009, 0.8776]], 0.0)
    """
    q, w = np.array(q0, float), np.array(w0, float)
    pole = np.array([0.0, 0.0, 1.0 if q[body, 2] >= 0 else -1.0])
    turn = np.cross(q[body], pole)
    if np.linalg.norm(turn) > 0:
        angle = np.arctan2(np.linalg.norm(turn), np.dot(q[body], pole))
        onto = _rotation(turn / np.linalg.norm(turn), angle)
        q[body], w[body] = pole, onto @ w[body]
    if not np.linalg.norm(w[body]) > 0:
        raise ValueError(f"body {body + 1} does not move; it cannot be sent past the pole")
    axis = w[body] / np.linalg.norm(w[body])
    motion = np.cross(axis, q[body])
    rot = _rotation(motion / np.linalg.norm(motion), beta) @ _rotation(axis, -alpha)
    q[body], w[body] = rot @ q[body], rot @ w[body]
    return q, w


def _passage(
    system: System, s: Settings, state: tuple[np.ndarray, np.ndarray], body: int, window: float
) -> tuple[float, float]:
    """(signed distance, time) of the body's closest pass by the e3 axis within `window`.

    The distance is that of the local tangent line, L_z / |v_xy| with L_z = (q x v) . e3, so
    it is accurate even when the pass falls between samples; its sign tells the side.
    """
    fine = s.h / 10
    opts = Options(rtol=_REFERENCE_RTOL, atol=_REFERENCE_ATOL, control=s.control)
    nsteps = max(1, int(np.ceil(window / fine)))
    tr = simulate(system, "rk45", "c", fine, nsteps * fine, opts, q0=state[0], omega0=state[1])
    q, w = tr.q[:, body], tr.omega[:, body]
    k = int(np.argmin(np.hypot(q[:, 0], q[:, 1])))
    v = np.cross(w[k], q[k])
    lz = q[k, 0] * v[1] - q[k, 1] * v[0]
    return float(lz / max(np.hypot(v[0], v[1]), 1e-300)), float(tr.t[k])


def through_tilt(system: System, s: Settings, body: int, iterations: int = 60) -> float:
    """The tilt beta* whose trajectory passes through the pole (bisection on the pass side).

    Returns 0 when +-0.25 rad do not bracket a passage (the body then passes near, not through).
    """
    assert system.q0 is not None and system.omega0 is not None
    speed = float(np.linalg.norm(system.omega0[body]))
    window = min(s.T, 3.0 * s.alpha / max(speed, 1e-12))

    def side(beta: float) -> float:
        q0, w0 = system.q0, system.omega0
        assert q0 is not None and w0 is not None
        state = tilted_state(q0, w0, body, s.alpha, beta)
        return _passage(system, s, state, body, window)[0]

    lo, hi = -0.25, 0.25
    slo, shi = side(lo), side(hi)
    if not slo * shi < 0:
        return 0.0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        smid = side(mid)
        if smid == 0.0 or hi - lo < 1e-15:
            return mid
        lo, hi, slo = (lo, mid, slo) if slo * smid < 0 else (mid, hi, smid)
    return 0.5 * (lo + hi)


@dataclass
class PoleCase:
    """One near-pole case: its label, tilt, the reference's pass of the pole, the runs."""

    label: str
    beta: float
    body: int
    passage: float  # distance of the designed pass from the pole (signed)
    passage_time: float
    sin_theta: np.ndarray  # |sin theta_body(t)| of the reference on the output grid
    runs: list[Run]


def pole_study(system: System, s: Settings, log: Callable[[str], None] = print) -> list[PoleCase]:
    """The tilt through the pole and the tilts beta* + delta for delta in `Settings.tilts`."""
    assert system.q0 is not None and system.omega0 is not None
    body = pole_body(system.q0)
    speed = float(np.linalg.norm(system.omega0[body]))
    window = min(s.T, 3.0 * s.alpha / max(speed, 1e-12))
    star = through_tilt(system, s, body)
    log(f"  body {body + 1}; tilt through the pole beta* = {star:.15g}")
    out = []
    for label, delta in [("through", 0.0)] + [(f"{d:g}", d) for d in s.tilts]:
        state = tilted_state(system.q0, system.omega0, body, s.alpha, star + delta)
        passage, when = _passage(system, s, state, body, window)
        ref = reference(system, s, state)
        sin_grid = np.hypot(ref[:, body, 0], ref[:, body, 1])
        runs = accuracy(system, s, state, ref, around=when)
        out.append(PoleCase(label, star + delta, body, passage, when, sin_grid, runs))
        for r in runs:
            log(f"  {label:>8s} (pass {passage:9.2e} at t {when:5.3f}) {_run_line(r)}")
    return out


# -------------------------------------------------------------------------------------- scaling
def chain_system(n: int) -> System:
    """n spherical pendula in a chain: M_ij = (sum_{k>=max(i,j)} m_k) l_i l_j, gravity along e3.

    Example:
        >>> chain_system(2).inertia
        Matrix([
        [l1**2*(m1 + m2), l1*l2*m2],
        [       l1*l2*m2, l2**2*m2]])
    """
    params: dict[str, float] = {}
    for i in range(1, n + 1):
        params[f"m{i}"], params[f"l{i}"] = 1.0, 1.0
    params["g"] = 9.81

    def tail(i: int) -> str:
        return "(" + " + ".join(f"m{k}" for k in range(i, n + 1)) + ")"

    inertia = [[f"{tail(max(i, j))}*l{i}*l{j}" for j in range(1, n + 1)] for i in range(1, n + 1)]
    potential = " + ".join(f"-{tail(i)}*g*l{i}*q{i}[2]" for i in range(1, n + 1))
    q, w = generic_state(n)
    return define_system(
        name=f"chain{n}",
        bodies=n,
        parameters=params,
        inertia=inertia,
        potential=potential,
        initial_q=q,
        initial_omega=w,
        origin=f"s2gen.compare_angles.chain_system({n})",
    )


def scaling(
    s: Settings, log: Callable[[str], None] = print, forms: Sequence[str] = FORMS
) -> list[Cost]:
    """Cost of every form for chains n = 1..chain_max; a form over budget is not retried."""
    out: list[Cost] = []
    over: dict[str, str] = {}
    for n in range(1, s.chain_max + 1):
        for c in costs(chain_system(n), forms, s.budget, s.repeats, over):
            if c.status != "ok":
                over.setdefault(c.form, c.status)
            log(f"  chain n={n:2d} {c.form:18s} {_cost_line(c)}")
            out.append(c)
    return out


def _cost_line(c: Cost) -> str:
    if c.status != "ok":
        return c.status
    return (
        f"derive {c.seconds:7.2f} s, {c.ops:6d} ops, gcc {c.gcc_seconds:5.2f} s, "
        f"rhs {c.rhs_ns:8.0f} ns"
    )


# ------------------------------------------------------------------------------------- the study
@dataclass
class Comparison:
    """Every result of one `compare` call."""

    system: str
    n: int
    settings: Settings
    costs: list[Cost]
    accuracy: list[Run]
    pole: list[PoleCase]
    chains: list[Cost]
    files: list[Path] = field(default_factory=list)


def compare(
    system: System,
    s: Settings,
    out: str | Path,
    log: Callable[[str], None] = print,
) -> Comparison:
    """Run the whole comparison and write the report, the JSON numbers and the figures."""
    log(f"{system.name}: cost of each form (derivations in subprocesses, budget {s.budget:g} s)")
    spec_costs = costs(system, FORMS, s.budget, s.repeats)
    for c in spec_costs:
        log(f"  {c.form:18s} {_cost_line(c)}")
    assert system.q0 is not None and system.omega0 is not None
    log(f"{system.name}: accuracy over T = {s.T:g} (rtol {s.rtol:g}, atol {s.atol:g}, h {s.h:g})")
    state = (system.q0, system.omega0)
    acc = accuracy(system, s, state, reference(system, s, state))
    for r in acc:
        log(f"  {_run_line(r)}")
    log(f"{system.name}: near a pole (alpha {s.alpha:g}, tilts {list(s.tilts)})")
    pole = pole_study(system, s, log)
    if s.chain_max > 0:
        log(f"chains n = 1..{s.chain_max}:")
    chains = scaling(s, log)
    result = Comparison(system.name, system.n, s, spec_costs, acc, pole, chains)
    result.files = write_all(result, Path(out))
    return result


def _run_line(r: Run) -> str:
    if r.status == "PoleError":
        return f"{r.form:6s} {r.method:5s} cannot start: {r.message}"
    tail = "" if r.status == "ok" else f"  FAILED at t = {r.t[-1] if r.t.size else 0:.4g}"
    return (
        f"{r.form:6s} {r.method:5s} max|q-qref| {r.max_error():.2e}  "
        f"max|dE| {r.summary.get('max_dE', float('nan')):.2e}  steps {r.steps:6d} "
        f"rejected {r.rejected:5d}{tail}"
    )


# ------------------------------------------------------------------------------------------ CLI
def add_parser(subparsers: Any) -> None:
    """Register `compare-angles` on an argparse subparsers object (wired in by cli.py)."""
    d = Settings()
    p = subparsers.add_parser(
        "compare-angles",
        help="compare the (S^2)^n form with the classical spherical-angle form",
        description="Generate both forms from the same system and compare derivation time, "
        "operations, code size, gcc time, time per vector-field evaluation and accuracy; "
        "study trajectories near a pole and chains of n pendula. Writes compare_angles.md, "
        "compare_angles.json and PNG figures.",
    )
    p.add_argument("spec", metavar="SPEC")
    p.add_argument("--out", help="output folder (default out/compare_angles/<name>)")
    p.add_argument("--T", type=float, default=d.T, help=f"final time (default {d.T:g})")
    p.add_argument("--h", type=float, default=d.h, help=f"RK4 step, RK45 output grid ({d.h:g})")
    p.add_argument("--rtol", type=float, default=d.rtol, help=f"RK45 rtol (default {d.rtol:g})")
    p.add_argument("--atol", type=float, default=d.atol, help=f"RK45 atol (default {d.atol:g})")
    p.add_argument("--control", choices=("matlab", "hairer"), default=d.control)
    p.add_argument("--budget", type=float, default=d.budget, help="seconds per derivation")
    p.add_argument("--tilts", type=_floats, default=d.tilts, help="near-pole tilts, e.g. 1e-2,1e-4")
    p.add_argument("--alpha", type=float, default=d.alpha, help="near-pole back-up angle (rad)")
    p.add_argument("--chain-max", type=int, default=d.chain_max, help="largest chain (0: none)")
    p.add_argument("--repeats", type=int, default=d.repeats, help="timing repeats (best of)")
    p.add_argument("--quick", action="store_true", help="short runs (T 2, chains to 3)")


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}"
        ) from None


def settings_from_args(args: argparse.Namespace) -> Settings:
    """Settings from parsed arguments (`--quick` replaces the defaults it shortens)."""
    base = Settings.quick() if args.quick else Settings()
    given = {
        k: getattr(args, k)
        for k in ("T", "h", "rtol", "atol", "control", "budget", "alpha", "repeats", "tilts")
        if getattr(args, k) != getattr(Settings(), k)
    }
    if args.chain_max != Settings().chain_max:
        given["chain_max"] = args.chain_max
    return replace(base, **given)


def run(args: argparse.Namespace) -> int:
    """Run `compare-angles` from parsed arguments; 0 on success."""
    from .systems import resolve

    system = resolve(args.spec)
    if system.q0 is None or system.omega0 is None:
        print(f"error: {system.origin}: no initial state ([initial] q and omega)", file=sys.stderr)
        return 2
    s = settings_from_args(args)
    out = Path(args.out or Path("out") / "compare_angles" / system.name)
    start = time.perf_counter()
    result = compare(system, s, out, log=lambda line: print(line, flush=True))
    print(f"done in {time.perf_counter() - start:.1f} s; outputs in {out}/:")
    for path in result.files:
        print(f"  {path}")
    return 0


def to_json(result: Comparison) -> dict[str, Any]:
    """The scalar results as plain JSON data."""
    return {
        "system": result.system,
        "settings": asdict(result.settings),
        "costs": [asdict(c) for c in result.costs],
        "accuracy": [r.brief() for r in result.accuracy],
        "pole": [
            {"label": c.label, "beta": c.beta, "body": c.body + 1, "passage": c.passage}
            | {"passage_time": c.passage_time}
            | {"runs": [r.brief() for r in c.runs]}
            for c in result.pole
        ],
        "chains": [asdict(c) for c in result.chains],
    }


def write_json(result: Comparison, path: Path) -> Path:
    path.write_text(json.dumps(to_json(result), indent=1, default=float) + "\n")
    return path


# ------------------------------------------------------------------------------------ the report
def _num(x: float, spec: str = ".3g") -> str:
    return "–" if x is None or not np.isfinite(x) else format(x, spec)


def _result(r: Run) -> str:
    if r.status == "ok":
        return "ok"
    if r.status == "PoleError":
        return "cannot start (body at a pole)"
    reached = float(r.t[-1]) if r.t.size else 0.0
    why = r.message.split(": ", 1)[-1].split(";")[0]
    return f"failed at t ≈ {reached:.3g}: {why}"


def _cost_rows(costs: Sequence[Cost]) -> list[str]:
    by = {c.form: c for c in costs}
    cols = [by[f] for f in FORMS if f in by]

    def row(name: str, fn: Callable[[Cost], str]) -> str:
        return (
            f"| {name} | "
            + " | ".join(fn(c) if c.status == "ok" else c.status for c in cols)
            + " |"
        )

    head = "| | " + " | ".join(_LABELS[c.form] for c in cols) + " |"
    return [
        head,
        "|---|" + "---:|" * len(cols),
        row("derivation + cse of the vector field (s)", lambda c: f"{c.seconds:.2f}"),
        row("… of every kernel of the emitted module (s)", lambda c: f"{c.module_seconds:.2f}"),
        row("vector-field kernel operations, as derived", lambda c: f"{c.ops_before}"),
        row("… after cse", lambda c: f"{c.ops}"),
        row("… after cse, as evaluated per call", lambda c: f"{c.ops_evaluated}"),
        row("linear solve per call (≈ flops)", lambda c: f"{c.solve_flops}"),
        row("emitted C, .c + .h (bytes / lines)", lambda c: f"{c.c_bytes} / {c.c_lines}"),
        row("gcc -O2 -shared (s)", lambda c: f"{c.gcc_seconds:.2f}"),
        row("time per vector-field evaluation (ns, C)", lambda c: f"{c.rhs_ns:.0f}"),
    ]


def _run_rows(runs: Sequence[Run], prefix: str = "") -> list[str]:
    rows = []
    for r in runs:
        sm = r.summary
        rows.append(
            f"| {prefix}{_LABELS[r.form]} | {r.method.upper()} | {_result(r)} | "
            f"{_num(r.max_error(), '.2e')} | {_num(sm.get('mean_dE', np.nan), '.2e')} | "
            f"{_num(sm.get('max_dE', np.nan), '.2e')} | "
            f"{_num(sm.get('max_norm', np.nan), '.1e')} | "
            f"{r.steps} | {r.rejected} | {r.evals} | {_num(1e3 * r.wall, '.2f')} |"
        )
    return rows


_RUN_HEAD = [
    (
        "| form | method | result | max ‖q − q_ref‖ | mean \\|E − E₀\\| | max \\|E − E₀\\| | "
        "max \\| \\|q\\| − 1 \\| | steps | rejected | evaluations | wall (ms) |"
    ),
    "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
]


def _pole_rows(cases: Sequence[PoleCase]) -> list[str]:
    head = [
        (
            "| case | pass distance | at t | form | method | result | max ‖q − q_ref‖ | "
            "max \\|E − E₀\\| | steps | rejected |"
        ),
        "|---|---:|---:|---|---|---|---:|---:|---:|---:|",
    ]
    rows = []
    for c in cases:
        for r in c.runs:
            rows.append(
                f"| {c.label} | {_num(abs(c.passage), '.2e')} | {_num(c.passage_time, '.3f')} | "
                f"{_LABELS[r.form]} | {r.method.upper()} | {_result(r)} | "
                f"{_num(r.max_error(), '.2e')} | {_num(r.summary.get('max_dE', np.nan), '.2e')} | "
                f"{r.steps} | {r.rejected} |"
            )
    return head + rows


def _chain_rows(chains: Sequence[Cost]) -> list[str]:
    ns = sorted({c.n for c in chains})
    by = {(c.form, c.n): c for c in chains}
    head = (
        "| n | derive + cse (s): S² / angles / simplified | S² kernel ops after cse | "
        "ops after cse per call: S² / angles / simplified | "
        "vector field (ns): S² / angles / simplified | gcc (s): S² / angles |"
    )
    rows = [head, "|---:|---|---:|---|---|---|"]

    def cell(n: int, fn: Callable[[Cost], str], forms: Sequence[str] = FORMS) -> str:
        out = []
        for f in forms:
            c = by.get((f, n))
            out.append("–" if c is None else fn(c) if c.status == "ok" else c.status)
        return " / ".join(out)

    for n in ns:
        rows.append(
            f"| {n} | {cell(n, lambda c: f'{c.seconds:.2f}')} | "
            f"{cell(n, lambda c: f'{c.ops}', FORMS[:1])} | "
            f"{cell(n, lambda c: f'{c.ops_evaluated}')} | {cell(n, lambda c: f'{c.rhs_ns:.0f}')} | "
            f"{cell(n, lambda c: f'{c.gcc_seconds:.2f}', FORMS[:2])} |"
        )
    return rows


def markdown(result: Comparison, figures: Sequence[Path]) -> str:
    """The report as Markdown text."""
    s = result.settings
    pole = result.pole[0] if result.pole else None
    lines = [
        f"# The (S²)ⁿ form against the spherical-angle form: {result.system}",
        "",
        (
            f"Both forms are generated from the same (M, V) of `{result.system}` "
            f"(n = {result.n}) and run as emitted C. Angle form: "
            "qᵢ = (sin θᵢ cos φᵢ, sin θᵢ sin φᵢ, cos θᵢ), "
            "M(θ, φ) ẍ = F solved by LU with partial pivoting; results are mapped back to "
            "(qᵢ, ωᵢ = qᵢ × q̇ᵢ) and every metric, the energy included, is computed on those as "
            "for the S² form."
        ),
        "",
        (
            f"Settings: T = {s.T:g}, h = {s.h:g} (RK4 step and RK45 output grid), RK45 rtol = "
            f"{s.rtol:g}, atol = {s.atol:g} ({s.control} error control); reference: S² RK45 at "
            f"rtol {_REFERENCE_RTOL:g}, atol {_REFERENCE_ATOL:g}; derivation budget {s.budget:g} s."
        ),
        "",
        "## Cost",
        "",
        *_cost_rows(result.costs),
        "",
        (
            "Derivation times are measured in a fresh process (cold SymPy caches). The S² "
            "vector field is its generic per-body and per-pair kernels (derived for a generic "
            "body and pair, whatever n) plus M and ∂V/∂q; its module also holds the variational "
            "integrators' kernels, so its module time, C size and gcc time cover more than the "
            "vector field. Operations are SymPy `count_ops` of the vector-field kernels; per call, "
            "the S² per-body and per-pair kernels count once per body and per coupled pair. "
            "Linear solve: S² Cholesky of the 3n × 3n matrix A(q) (coupled M only), angle form LU "
            "of the 2n × 2n M(θ, φ). Times per evaluation: the forms timed side by side, best of "
            f"{s.repeats} loops of about 20 ms, at a state away from the poles."
        ),
        "",
        f"## Accuracy over T = {s.T:g}",
        "",
        *_RUN_HEAD,
        *_run_rows(result.accuracy),
        "",
    ]
    if pole is not None:
        lines += [
            f"## Near a pole: body {pole.body + 1}",
            "",
            (
                f"The spec's own state is in the accuracy table above. Here body "
                f"{pole.body + 1} is turned onto its nearest pole, moved back along its motion "
                f"by α = {s.alpha:g} rad and tilted by β about its direction of motion. "
                "`through` uses the tilt β* (bisection on the side of the pass; "
                f"β* = {pole.beta:.12g}) whose trajectory passes through the pole; case δ uses "
                "β* + δ. Pass distance: |L_z|/|v_xy| of the reference at its sample closest to "
                "the pole (the distance of the local tangent line; exact between samples)."
            ),
            "",
            *_pole_rows(result.pole),
            "",
        ]
    if result.chains:
        lines += [
            "## Scaling: chains of n spherical pendula",
            "",
            (
                "M_ij = (Σ_{k ≥ max(i,j)} m_k) l_i l_j, V = −Σ_i (Σ_{k ≥ i} m_k) g l_i e₃·q_i "
                "(`compare_angles.chain_system`). A form that exceeds the derivation budget is not "
                "tried for larger n."
            ),
            "",
            *_chain_rows(result.chains),
            "",
        ]
    lines += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in figures] + [""]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------ the figures
_FORM_STYLE: dict[str, dict[str, Any]] = {
    "s2": {"color": "tab:red", "linestyle": "-"},
    "angles": {"color": "tab:blue", "linestyle": "--"},
    "angles-simplified": {"color": "tab:green", "linestyle": ":"},
}


def _save(fig: Any, path: Path) -> Path:
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def _positive(y: np.ndarray) -> np.ndarray:
    return np.maximum(y, 1e-17)


def _error_panel(ax: Any, runs: Sequence[Run], method: str, title: str) -> None:
    for r in runs:
        if r.method != method or not r.t.size:
            continue
        style = _FORM_STYLE[r.form]
        ax.semilogy(r.t, _positive(r.error), label=_LABELS[r.form], **style)
        if r.status != "ok":
            ax.plot(r.t[-1], _positive(r.error[-1:])[0], "x", color=style["color"], ms=9)
    ax.set_title(title)
    ax.set_xlabel("t")
    ax.set_ylabel("max ‖qᵢ − qᵢ,ref‖")
    ax.set_ylim(bottom=1e-12)
    ax.grid(True, which="both", alpha=0.3)


def accuracy_figure(result: Comparison, path: Path) -> Path:
    """State and energy error against time, RK45 and RK4, both forms, for the spec's state."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 7), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    for col, method in enumerate(("rk45", "rk4")):
        ax, ax_e = axes[0, col], axes[1, col]
        _error_panel(ax, result.accuracy, method, f"{result.system}: {method.upper()}")
        for r in (r for r in result.accuracy if r.method == method and r.t.size):
            ax_e.semilogy(
                r.t, _positive(r.energy_error), label=_LABELS[r.form], **_FORM_STYLE[r.form]
            )
        for r in (r for r in result.accuracy if r.method == method and r.status == "PoleError"):
            note = f"{_LABELS[r.form]}: cannot start, {r.message.split(':')[0]}"
            color = _FORM_STYLE[r.form]["color"]
            ax.text(0.02, 0.02, note, transform=ax.transAxes, fontsize=8, color=color)
        ax.legend(fontsize=8)
        ax_e.set_ylabel("|E − E₀|")
        ax_e.set_xlabel("t")
        ax_e.set_ylim(bottom=1e-12)
        ax_e.grid(True, which="both", alpha=0.3)
    return _save(fig, path)


def _case_colors(cases: Sequence[PoleCase]) -> dict[str, Any]:
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    return {c.label: cmap(k / max(1, len(cases) - 1)) for k, c in enumerate(cases)}


def _window(data: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Rows of (t, ...) data with lo <= t <= hi, counts relative to the first of them."""
    rows = data[(data[:, 0] >= lo - 1e-12) & (data[:, 0] <= hi + 1e-12)]
    return rows - np.r_[0.0, rows[0, 1:]] if len(rows) else rows


def _steps_column(axes: Any, result: Comparison, zoom: bool) -> None:
    """Accepted and rejected steps and |sin theta| of every case, over [0, T] or the zoom."""
    colors = _case_colors(result.pole)
    tp = result.pole[0].passage_time
    lo, hi = (tp - ZOOM, tp + ZOOM) if zoom else (0.0, result.settings.T)
    for c in result.pole:
        for r in (r for r in c.runs if r.method == "rk45" and r.counts.size):
            data = _window(r.counts, lo, hi)
            if not len(data):
                continue
            ls = "-" if r.form == "angles" else "--"
            axes[0].plot(
                data[:, 0],
                data[:, 1],
                ls,
                color=colors[c.label],
                label=f"{c.label}: {_LABELS[r.form]}",
            )
            axes[1].plot(data[:, 0], data[:, 2], ls, color=colors[c.label])
            if r.status != "ok":
                axes[0].plot(data[-1, 0], data[-1, 1], "x", color=colors[c.label], ms=10)
        t = result.settings.h * np.arange(len(c.sin_theta))
        keep = (t >= lo) & (t <= hi)
        axes[2].semilogy(
            t[keep], _positive(c.sin_theta[keep]), color=colors[c.label], label=c.label
        )
    since = f" since t = {lo:.3g}" if zoom else ""
    axes[0].set_ylabel(f"accepted RK45 steps{since}")
    axes[1].set_ylabel(f"rejected RK45 steps{since}")
    axes[2].set_ylabel(f"|sin θ{result.pole[0].body + 1}| (reference)")
    axes[2].set_xlabel("t")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)


def pole_steps_figure(result: Comparison, path: Path) -> Path:
    """Accepted and rejected RK45 steps and |sin theta| of the reference per case: over the
    whole run (left) and around the designed pass (right)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 9), layout="constrained")
    grid = fig.subplots(3, 2, sharex="col")
    _steps_column(grid[:, 0], result, zoom=False)
    _steps_column(grid[:, 1], result, zoom=True)
    fig.suptitle(
        f"{result.system}: RK45 near a pole (solid: angle form, dashed: S² form; x: failure); "
        f"right: t = {result.pole[0].passage_time:.3g} ± {ZOOM:g}"
    )
    grid[0, 0].legend(fontsize=7, ncol=2)
    grid[2, 1].legend(fontsize=7, ncol=3)
    return _save(fig, path)


def pole_error_figure(result: Comparison, path: Path) -> Path:
    """Error against time near a pole: RK45 and RK4, both forms, every case."""
    from matplotlib.figure import Figure

    cases = result.pole
    colors = _case_colors(cases)
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    for ax, method in zip(axes, ("rk45", "rk4")):
        for c in cases:
            for r in c.runs:
                if r.method != method or not r.t.size:
                    continue
                ls = "-" if r.form == "angles" else "--"
                ax.semilogy(
                    r.t,
                    _positive(r.error),
                    ls,
                    color=colors[c.label],
                    label=f"{c.label}: {_LABELS[r.form]}",
                )
                if r.status != "ok":
                    ax.plot(r.t[-1], _positive(r.error[-1:])[0], "x", color=colors[c.label])
        ax.set_title(f"{method.upper()} (solid: angle form, dashed: S² form; x: failure)")
        ax.set_ylim(bottom=1e-12)
        ax.set_xlabel("t")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("max ‖qᵢ − qᵢ,ref‖")
    axes[0].legend(fontsize=7, ncol=2)
    return _save(fig, path)


def scaling_figure(result: Comparison, path: Path) -> Path:
    """Derivation time, operations and vector-field time against n for the chains."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4), layout="constrained")
    axes = fig.subplots(1, 3)
    metrics_ = (
        ("seconds", "derivation + cse (s)"),
        ("ops_evaluated", "operations after cse, per call"),
        ("rhs_ns", "vector field (ns, C)"),
    )
    for ax, (key, label) in zip(axes, metrics_):
        for form in FORMS:
            done = [c for c in result.chains if c.form == form and c.status == "ok"]
            if done:
                ax.semilogy(
                    [c.n for c in done],
                    [getattr(c, key) for c in done],
                    "o",
                    label=_LABELS[form],
                    **_FORM_STYLE[form],
                )
            if done and form == "s2" and key == "ops_evaluated":
                ax.semilogy(
                    [c.n for c in done],
                    [c.ops for c in done],
                    "s:",
                    color="tab:red",
                    label="S² form, kernels (text)",
                )
            over = [c for c in result.chains if c.form == form and c.status != "ok"]
            if over and key == "seconds":
                ax.plot(over[0].n, result.settings.budget, "^", color=_FORM_STYLE[form]["color"])
        ax.set_xlabel("bodies n")
        ax.set_title(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].axhline(result.settings.budget, color="gray", lw=0.8)
    axes[0].legend(fontsize=8, title="▲: over budget", loc="lower right")
    axes[1].legend(fontsize=8)
    return _save(fig, path)


def write_all(result: Comparison, out: Path) -> list[Path]:
    """Write the figures, compare_angles.md and compare_angles.json into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    figures = [accuracy_figure(result, out / "accuracy.png")]
    if len(result.pole) > 1:
        figures.append(pole_steps_figure(result, out / "pole_steps.png"))
        figures.append(pole_error_figure(result, out / "pole_error.png"))
    if result.chains:
        figures.append(scaling_figure(result, out / "scaling.png"))
    md = out / "compare_angles.md"
    md.write_text(markdown(result, figures))
    return [md, write_json(result, out / "compare_angles.json"), *figures]
