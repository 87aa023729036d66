"""The stability envelope: how large a step each fixed-step method survives on hard cases.

Input: `quick`. Output: the hard cases (`stability_cases`: a pole, stiff rods, a close
Lennard-Jones encounter, near-singular inertia, large n) and, for each case and method of
`FIXED`, the runs of an upward sweep of h (`StabRow`), from a stable start until the first
failure; `largest_stable` and `_first_failure` read a sweep.

Example:
    >>> [c.label for c in stability_cases(quick=True)][-1]
    'near-singular M m2/m1=1e+04'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from s2gen import IntegrationError, Options, System, simulate
from s2gen.inspect import get_backend

from .common import Log, _fmt, _print, _why, example_system, kinetic_energy
from .model import FIXED, SAMPLES, StabilityCase, StabRow


def _lj_encounter() -> System:
    """Three Lennard-Jones particles; bodies 1 and 2 meet head-on (closest approach ~0.8 sigma)."""
    from s2gen import define

    a = 0.3
    q = [[math.cos(a), -math.sin(a), 0.0], [math.cos(a), math.sin(a), 0.0], [0.0, 0.0, 1.0]]
    w = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.2, 0.0, 0.0]]
    r2 = "dot(qi-qj, qi-qj)"
    return define(
        name="lj_encounter",
        bodies=3,
        parameters={"m": 1.0, "eps": 1.0, "sigma": 0.1},
        diagonal=["m"] * 3,
        pair_terms=[{"V": f"4*eps*((sigma**2/{r2})**6 - (sigma**2/{r2})**3)", "pairs": "all"}],
        initial_q=q,
        initial_omega=w,
        run={"h": 1e-4, "T": 0.6},
        origin="s2gen.bench._lj_encounter",
    )


def _with(system: System, **values: float) -> np.ndarray:
    p = dict(system.parameters)
    p.update(values)
    return np.array([p[k] for k in system.parameter_names], dtype=float)


def stability_cases(quick: bool = False) -> list[StabilityCase]:
    """The hard cases: poles, a stiff rod, a close encounter, near-singular M, large n.

    Example:
        >>> [c.label for c in stability_cases(quick=True)][:2]
        ['poles: double pendulum', 'stiff rod kappa=1e+03']
    """
    from s2gen import paper

    dp = example_system("double_pendulum")
    rod = paper.elastic_rod(5 if quick else 10)
    cases = [
        StabilityCase(
            "poles: double pendulum",
            dp,
            _with(dp),
            5.0,
            "body 2 starts at e3, the pole of the polar-angle chart",
        ),
    ]
    for kappa in (1e3, 1e5) if quick else (1e3, 1e4, 1e5):
        cases.append(
            StabilityCase(
                f"stiff rod kappa={kappa:.0e}",
                rod,
                _with(rod, kappa=kappa),
                0.1,
                f"elastic_rod(n={rod.n}) with bending stiffness {kappa:g} N m",
            )
        )
    lj = _lj_encounter()
    cases.append(
        StabilityCase(
            "LJ close encounter",
            lj,
            _with(lj),
            0.6,
            "two particles meet head-on at 2 rad/s, sigma = 0.1",
        )
    )
    for ratio in (1e2, 1e4) if quick else (1e2, 1e4, 1e6):
        cases.append(
            StabilityCase(
                f"near-singular M m2/m1={ratio:.0e}",
                dp,
                _with(dp, m1=1.0 / ratio),
                2.0,
                f"double pendulum with m1 = m2/{ratio:g}: cond(M) grows with m2/m1",
            )
        )
    if not quick:
        big = paper.elastic_rod(40)
        cases.append(
            StabilityCase(
                "large n: rod n=40",
                big,
                _with(big),
                0.1,
                "elastic_rod(n=40): coupled 40 x 40 inertia",
            )
        )
        md = paper.molecular(1)
        cases.append(
            StabilityCase(
                "large n: LJ n=42",
                md,
                _with(md),
                2.0,
                "molecular(subdivisions=1): 42 particles, all pairs",
            )
        )
    return cases


def _stab_run(case: StabilityCase, method: str, n: int, ref: dict[str, Any]) -> StabRow:
    h = case.T / n
    hw = h * ref["wmax"]
    try:
        tr = simulate(case.system, method, "c", h=h, T=case.T, params=case.params)
    except IntegrationError as exc:
        return StabRow(case.label, method, h, n, hw, math.nan, math.nan, 0, _why(exc))
    if not (np.all(np.isfinite(tr.q)) and np.all(np.isfinite(tr.omega))):
        return StabRow(case.label, method, h, n, hw, math.nan, math.nan, 0, "failed (non-finite)")
    err = max(
        float(np.max(np.abs(tr.q[-1] - ref["q"]))),
        float(np.max(np.abs(tr.omega[-1] - ref["w"]))) / ref["wmax"],
        float(np.max(np.abs(tr.energy - tr.energy[0]))) / ref["kin"],
    )
    newton = tr.stats.get("newton_iters", 0) / n
    status = "ok" if err <= 1.0 else "failed (error > 1)"
    return StabRow(case.label, method, h, n, hw, err, newton, tr.stats.get("newton_max", 0), status)


def _stab_reference(case: StabilityCase) -> dict[str, Any]:
    opts = Options(rtol=1e-11, atol=1e-11, control="hairer")
    tr = simulate(
        case.system, "rk45", "c", h=case.T / SAMPLES, T=case.T, options=opts, params=case.params
    )
    wmax = float(np.max(np.linalg.norm(tr.omega, axis=-1)))
    kin = float(np.max(kinetic_energy(case.system, tr.q, tr.omega, case.params)))
    return {"q": tr.q[-1], "w": tr.omega[-1], "wmax": wmax, "kin": kin, "steps": tr.stats["steps"]}


def stability_sweep(case: StabilityCase, method: str, ref: dict[str, Any]) -> list[StabRow]:
    """Runs of one method with h growing by 2^(1/4) from a stable start until the first failure.

    Example:
        >>> c = stability_cases(quick=True)[0]
        >>> rows = stability_sweep(c, "rk4", _stab_reference(c))  # doctest: +SKIP
        >>> rows[-1].status.startswith("failed")  # doctest: +SKIP
        True
    """
    rows: list[StabRow] = []
    n = 64
    while True:  # find a stable start, refining if needed
        row = _stab_run(case, method, n, ref)
        rows.append(row)
        if row.status == "ok" or n >= 2**20:
            break
        n *= 4
    k = 0
    while row.status == "ok":
        k += 1
        m = round(n * 2 ** (-k / 4))
        if m < 1 or m == rows[-1].steps:
            break
        row = _stab_run(case, method, m, ref)
        rows.append(row)
    return rows


def largest_stable(rows: Sequence[StabRow]) -> StabRow | None:
    """The largest h that ran ok in a sweep (None if none did).

    Example:
        >>> rows = [StabRow("c", "vi", h, 1, h, 0.1, 0, 0, s)
        ...         for h, s in ((0.1, "ok"), (0.2, "ok"), (0.3, "failed (newton at step 2)"))]
        >>> largest_stable(rows).h
        0.2
    """
    ok = [r for r in rows if r.status == "ok"]
    return max(ok, key=lambda r: r.h) if ok else None


def _first_failure(rows: Sequence[StabRow], best: StabRow | None) -> StabRow | None:
    """The first failed run of a sweep at a larger h than `best` (any failure if None).

    Example:
        >>> rows = [StabRow("c", "vi", h, 1, h, 0.1, 0, 0, s)
        ...         for h, s in ((0.1, "ok"), (0.2, "failed (error > 1)"))]
        >>> _first_failure(rows, rows[0]).h
        0.2
    """
    return next((r for r in rows if r.status != "ok" and (not best or r.h > best.h)), None)


def stability(quick: bool = False, log: Log = _print) -> tuple[list[StabRow], list[StabilityCase]]:
    """Every hard case and fixed-step method: the runs of the upward h sweeps."""
    log("stability envelope: h grows by 2^(1/4) until each method fails")
    rows: list[StabRow] = []
    cases = stability_cases(quick)
    for case in cases:
        get_backend(case.system, "c")
        try:
            ref = _stab_reference(case)
        except IntegrationError as exc:
            case.skipped = f"the RK45 reference (tol 1e-11) itself failed: {exc}"
            log(f"  {case.label}: skipped; {case.skipped}")
            continue
        log(f"  {case.label}: T = {case.T:g}, max |omega| = {ref['wmax']:.3g} ({case.note})")
        for method in FIXED:
            part = stability_sweep(case, method, ref)
            rows += part
            best = largest_stable(part)
            first_fail = _first_failure(part, best) if best else None
            log(
                f"    {method:9s} largest stable h {_fmt(best.h if best else None)} "
                f"(h max|w| {_fmt(best.h_wmax if best else None)}); then "
                f"{first_fail.status if first_fail else 'no failure'}"
            )
    return rows, cases
