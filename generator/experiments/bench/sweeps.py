"""Work-precision sweeps of one example: our integrators and the outside peers.

Input: an example name, `quick`, an optional horizon T and PyDy's code generator. Output: an
`ExampleBench` whose `rows` hold one `WPRow` per run (fixed-step methods over h = T/N, the
time-transformed ones over eps = T/N where the emitted C has them: the VI of every order and
RATTLE of orders 4 and 8, `TIME_RATTLE`; RK45 under both error controls and DOP853 on the
emitted C, scipy's RK45/DOP853 and PyDy over tolerances), measured against a converged
`reference`; also the per-call overhead and the
per-step timings (`per_step.py`). `fitted_orders` turns the rows into convergence orders.
The full sweeps step h by 2^(1/4) and the tolerance by 10^(1/4), so that the cheapest run
below an error target is close to it; the quick ones by 2 and 100.

Example:
    >>> ex = work_precision("double_pendulum", quick=True, log=lambda s: None)  # doctest: +SKIP
    >>> sorted(fitted_orders(ex.rows, ex.reference.accuracy))[:2]  # doctest: +SKIP
    ['rattle', 'rk2']
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial

import numpy as np

from s2gen import IntegrationError, Options, System, Trajectory, simulate
from s2gen.experiments import peers
from s2gen.inspect import get_backend, lowered

from .common import Log, _best_wall, _err, _ms, _print, _state, _why, example_system, kinetic_energy
from .model import FIXED, REF_RTOL, SAMPLES, TIME_TRANSFORMED, ExampleBench, Reference, WPRow
from .per_step import newton_per_substep, per_step_times

#: Horizons (full, quick) of the work-precision sweeps, chosen so the reference is trustworthy.
HORIZONS = {"double_pendulum": (10.0, 2.0), "three_bodies": (10.0, 1.0), "dipoles": (1.0, 0.25)}


def reference(system: System, T: float, log: Log = _print) -> Reference:
    """C DOP853 (rtol = atol = 3e-14) cross-checked against vi8 and rattle8 (the same discrete
    flow, solved two ways with different round-off) at three small steps around the system's
    own h; the smallest discrepancy is the reference's stated accuracy.

    Example:
        >>> ref = reference(example_system("double_pendulum"), 1.0, log=lambda s: None)
        >>> ref.accuracy < 1e-11
        True
    """
    opts = Options(rtol=REF_RTOL, atol=REF_RTOL)
    tr = simulate(system, "dop853", "c", h=T / SAMPLES, T=T, options=opts)
    state = _state(tr)
    h0 = system.run.h or T / 1000
    n_check = max(64, 2 ** math.ceil(math.log2(T / h0)))
    gaps = {}
    for method in ("vi8", "rattle8"):
        for n in (n_check // 2, n_check, 2 * n_check):
            chk = simulate(system, method, "c", h=T / n, T=T, every=n)
            gaps[(method, n)] = float(np.linalg.norm(_state(chk) - state))
    (method, n), acc = min(gaps.items(), key=lambda kv: kv[1])
    kin = float(np.max(kinetic_energy(system, tr.q, tr.omega)))
    log(
        f"  reference: dop853 (tol {REF_RTOL:g}) over T = {T:g}: {tr.stats['steps']} steps; "
        f"{method} at h = T/{n} agrees to {acc:.2e} (closest of vi8 and rattle8 at h = "
        f"T/{n_check // 2}, T/{n_check}, T/{2 * n_check})"
    )
    return Reference(system, T, state, acc, kin, float(tr.energy[0]), tr.wall_time)


def _sweep_steps(system: System, T: float, quick: bool) -> list[int]:
    """Step counts (h = T/N) from coarse to fine: doubling (quick) or by 2^(1/4), over 12
    octaves (7 quick)."""
    h0 = system.run.h or T / 1000
    n0 = max(8, 2 ** round(math.log2(T / (16 * h0))))
    if quick:
        return [n0 * 2**k for k in range(7)]
    return sorted({round(n0 * 2 ** (k / 4)) for k in range(45)})


#: Fictitious steps of the run that measures a time-transformed chain's mean step (eps = T/N)
PROBE_STEPS = 4096


def _eps_steps(system: System, T: float, quick: bool) -> list[int]:
    """Fictitious step counts N (eps = T/N) of the time-transformed methods, coarse to fine,
    matched to the fixed-step sweep (`_sweep_steps`) two octaves coarser: eps = T/N takes
    about a quarter as many steps in time as h = T/n does (adaptive steps resolve the
    encounters with fewer), the ratio measured by one fine run of ``vi-adaptive`` (eps =
    T/`PROBE_STEPS`); so the sweep starts where the methods resolve the motion, not at an eps
    whose chain wanders off (or fails: no real root for the step size)."""
    steps = _sweep_steps(system, T, quick)
    try:
        probe = simulate(
            system, "vi-adaptive", "c", h=T / PROBE_STEPS, T=T, every=PROBE_STEPS, energy=False
        )
    except IntegrationError:
        return steps
    ratio = PROBE_STEPS / max(int(probe.stats["steps"]), 1) / 4
    return sorted({max(1, round(n * ratio)) for n in steps})


def has_transformed(system: System) -> bool:
    """Whether the emitted C of `system` has the time-transformed driver: a closed system with
    monitored pair terms (none within a cutoff) or a monitor given as [run] g.

    Example:
        >>> has_transformed(example_system("three_bodies"))
        True
        >>> has_transformed(example_system("double_pendulum"))
        False
    """
    return "transformed" in lowered(system).parts


def _runs(
    system: System, method: str, h: float, T: float, k: int, options: Options | None = None
) -> tuple[Trajectory, Trajectory]:
    """The timed run (best of k, keeping only the final state and no energy, so that storing
    and energy evaluations cost nothing) and the sampled run (every step, or every h for the
    adaptive methods, with its energy)."""
    n = round(T / h)
    timed = partial(simulate, system, method, "c", h=h, T=T, options=options, every=n, energy=False)
    return _best_wall(timed, k), simulate(system, method, "c", h=h, T=T, options=options)


def _our_row(
    name: str,
    method: str,
    runs: tuple[Trajectory, Trajectory],
    ref: Reference,
    rtol: float = float("nan"),
) -> WPRow:
    tr, sampled = runs
    steps = int(tr.stats.get("steps", len(tr.t) - 1))
    newton = tr.stats.get("newton_iters", 0) / max(steps, 1)
    assert sampled.energy is not None
    dE = float(np.max(np.abs(sampled.energy - sampled.energy[0])))
    return WPRow(
        name,
        method,
        "s2gen",
        tr.h if method in FIXED or method in TIME_TRANSFORMED else float("nan"),
        rtol,
        ref.T,
        steps,
        int(tr.stats.get("gradient_evals", 0)),
        newton,
        tr.wall_time,
        _err(tr.q[-1], tr.omega[-1], ref.state),
        dE,
        dE / ref.kinetic_scale,
    )


def _failed_row(
    name: str, method: str, family: str, h: float, rtol: float, T: float, why: str
) -> WPRow:
    nan = float("nan")
    return WPRow(name, method, family, h, rtol, T, 0, 0, nan, nan, nan, nan, nan, why)


def _fixed_sweep(
    name: str, method: str, ref: Reference, steps: Sequence[int], budget: float, k: int, log: Log
) -> list[WPRow]:
    """`method` at h = T/N (a time-transformed one at eps = T/N) for N in `steps`, until its
    error reaches 30x the reference accuracy, grows past 10x its smallest so far once that
    is below 1e-4 (round-off has taken over: more steps only add to it) or a run takes longer
    than `budget`."""
    rows: list[WPRow] = []
    best = math.inf
    for n in steps:
        h = ref.T / n
        try:
            runs = _runs(ref.system, method, h, ref.T, k)
        except IntegrationError as exc:
            rows.append(_failed_row(name, method, "s2gen", h, math.nan, ref.T, _why(exc)))
            continue
        row = _our_row(name, method, runs, ref)
        rows.append(row)
        worse = best < 1e-4 and row.state_err > 10 * best
        best = min(best, row.state_err)
        if row.state_err < 30 * ref.accuracy or worse or row.wall > budget:
            break
    log(f"    {method:16s} {_sweep_line(rows)}")
    return rows


def _sweep_line(rows: Sequence[WPRow]) -> str:
    ok = [r for r in rows if r.status == "ok"]
    if not ok:
        return "all runs failed"
    a, b = ok[0], ok[-1]
    return (
        f"{len(rows)} runs, {a.setting}: err {a.state_err:.1e} ({_ms(a.wall)}) ... "
        f"{b.setting}: err {b.state_err:.1e} ({_ms(b.wall)})"
    )


def _tolerances(quick: bool, fine: bool = False) -> list[float]:
    """Tolerances from 1e-3 down: 1e-3, 1e-5, ..., 1e-9 (quick); 1e-3 ... 1e-12 by decades
    (peers) or by 10^(1/4) down to 1e-13 (`fine`: our adaptive methods)."""
    if quick:
        return [10.0**-k for k in range(3, 11, 2)]
    if fine:
        return [10.0 ** (-k / 4) for k in range(12, 53)]
    return [10.0**-k for k in range(3, 13)]


def _adaptive_sweep(
    name: str, method: str, control: str, ref: Reference, quick: bool, k: int, log: Log
) -> list[WPRow]:
    """RK45 (rows named rk45-<control>) or DOP853 over tolerances, samples every T/SAMPLES."""
    label = f"rk45-{control}" if method == "rk45" else method
    rows: list[WPRow] = []
    for tol in _tolerances(quick, fine=True):
        opts = Options(rtol=tol, atol=tol, control=control)
        try:
            runs = _runs(ref.system, method, ref.T / SAMPLES, ref.T, k, opts)
            rows.append(_our_row(name, label, runs, ref, tol))
        except IntegrationError as exc:
            rows.append(_failed_row(name, label, "s2gen", math.nan, tol, ref.T, _why(exc)))
    log(f"    {label:11s} {_sweep_line(rows)}")
    return rows


def _peer_row(name: str, family: str, r: peers.PeerRun, ref: Reference) -> WPRow:
    return WPRow(
        name,
        r.name,
        family,
        math.nan,
        r.rtol,
        r.T,
        r.steps,
        r.evals,
        math.nan,
        r.wall,
        _err(r.q, r.omega, ref.state) if r.status == "ok" else math.nan,
        r.max_dE,
        r.max_dE / ref.kinetic_scale,
        r.status,
    )


def _scipy_sweep(name: str, ref: Reference, quick: bool, k: int, log: Log) -> list[WPRow]:
    rows = []
    for method in ("RK45", "DOP853"):
        part = []
        for tol in _tolerances(quick):
            r = peers.scipy_run(ref.system, method, tol, ref.T, samples=SAMPLES, repeats=k)
            part.append(_peer_row(name, "scipy", r, ref))
        log(f"    {'scipy-' + method:12s} {_sweep_line(part)}")
        rows += part
    return rows


def _pydy_sweep(ex: ExampleBench, quick: bool, k: int, generator: str, log: Log) -> list[WPRow]:
    missing = peers.pydy_available()
    if missing:
        ex.pydy = {"status": f"PyDy could not be imported ({missing}); skipped"}
        log(f"    pydy: {ex.pydy['status']}")
        return []
    try:
        model = peers.pydy_model(ex.system, generator)
        ex.pydy = {
            "status": "ok",
            "generator": model.generator,
            "derive_s": model.derive_seconds,
            "generate_s": model.generate_seconds,
            "note": model.note,
        }
        log(
            f"    pydy ({model.generator}): derivation {model.derive_seconds:.2f} s, code "
            f"generation + compilation {model.generate_seconds:.2f} s {model.note}"
        )
        if generator == "auto" and model.generator == "cython":
            lam = peers.pydy_model(ex.system, "lambdify")
            ex.pydy["lambdify_generate_s"] = lam.generate_seconds
        rows = []
        for integrator in ("lsoda", "DOP853"):
            part = []
            for tol in _tolerances(quick):
                r = peers.pydy_run(
                    ex.system, model, integrator, tol, ex.reference.T, samples=SAMPLES, repeats=k
                )
                ex.pydy["pole_distance"] = r.extra.get("pole_distance", math.nan)
                part.append(_peer_row(ex.name, "pydy", r, ex.reference))
            log(f"    {part[0].method:12s} {_sweep_line(part)}")
            rows += part
        return rows
    except Exception as exc:  # noqa: BLE001 - a broken peer is reported, the bench goes on
        ex.pydy = {"status": f"PyDy failed: {type(exc).__name__}: {exc}"}
        log(f"    pydy: {ex.pydy['status']}")
        return []


def work_precision(
    name: str,
    quick: bool = False,
    T: float | None = None,
    pydy_generator: str = "auto",
    log: Log = _print,
) -> ExampleBench:
    """All methods and peers on one example over sweeps of h or tolerance.

    Example:
        >>> ex = work_precision("double_pendulum", quick=True, log=lambda s: None)  # doctest: +SKIP
        >>> {r.method for r in ex.rows} >= {"vi", "vi4", "rk45-hairer"}  # doctest: +SKIP
        True
    """
    system = example_system(name)
    full_T, quick_T = HORIZONS.get(name, (min(system.run.T or 10.0, 10.0),) * 2)
    T = T or (quick_T if quick else full_T)
    log(f"{name}: work-precision over T = {T:g} (n = {system.n})")
    get_backend(system, "c")
    ref = reference(system, T, log)
    ex = ExampleBench(name, system, ref)
    k = 3 if quick else 5
    budget = 0.5 if quick else 5.0
    steps = _sweep_steps(system, T, quick)
    for method in FIXED:
        ex.rows += _fixed_sweep(name, method, ref, steps, budget, k, log)
    if has_transformed(system):
        eps_steps = _eps_steps(system, T, quick)
        for method in TIME_TRANSFORMED:
            ex.rows += _fixed_sweep(name, method, ref, eps_steps, budget, k, log)
    for control in ("hairer", "matlab"):
        ex.rows += _adaptive_sweep(name, "rk45", control, ref, quick, k, log)
    ex.rows += _adaptive_sweep(name, "dop853", "hairer", ref, quick, k, log)
    ex.rows += _scipy_sweep(name, ref, quick, 2 if quick else 3, log)
    if system.parameter_names == ("m1", "m2", "l1", "l2", "g") and system.n == 2:
        gen = "lambdify" if quick and pydy_generator == "auto" else pydy_generator
        ex.rows += _pydy_sweep(ex, quick, 2 if quick else 3, gen, log)
    else:
        ex.pydy = {"status": f"the PyDy peer models the double pendulum only; not run on {name}"}
    ex.call_overhead = _call_overhead(system, T)
    ex.per_step = per_step_times(system, T, quick, log)
    ex.newton = newton_per_substep(system, log)
    return ex


def _call_overhead(system: System, T: float) -> float:
    """Best-of-20 wall time of a one-step call (output arrays, ctypes): in every timing above."""
    one = _best_wall(partial(simulate, system, "rk4", "c", h=T / SAMPLES, T=T / SAMPLES), 20)
    return one.wall_time


def fitted_orders(rows: Sequence[WPRow], floor: float) -> dict[str, float]:
    """Least-squares slope of log(state error) against log(h) per fixed-step method (and
    against log(eps) per time-transformed one).

    Uses the runs whose error lies between 100 x the reference accuracy and 1e-2 and whose h
    is at least that of the most accurate run (the asymptotic range: below it round-off
    grows), when there are at least three.

    Example:
        >>> rows = [WPRow("x", "vi", "s2gen", h, 0, 1, 0, 0, 0, 0, 3 * h**2, 0, 0)
        ...         for h in (0.01, 0.005, 0.0025)]
        >>> round(fitted_orders(rows, 1e-12)["vi"], 6)
        2.0
        >>> tail = WPRow("x", "vi", "s2gen", 0.001, 0, 1, 0, 0, 0, 0, 1e-3, 0, 0)  # round-off
        >>> round(fitted_orders([*rows, tail], 1e-12)["vi"], 6)
        2.0
    """
    out = {}
    for method in (*FIXED, *TIME_TRANSFORMED):
        pts = [
            (r.h, r.state_err)
            for r in rows
            if r.method == method and r.ok and 100 * floor < r.state_err < 1e-2
        ]
        if pts:
            finest = min(pts, key=lambda p: p[1])[0]
            pts = [p for p in pts if p[0] >= finest]
        if len(pts) >= 3:
            hs, es = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            out[method] = float(np.polyfit(hs, es, 1)[0])
    return out
