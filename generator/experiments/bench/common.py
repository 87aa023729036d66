"""Helpers shared by the measurements and the reports of `s2gen bench`.

Input: example names, trajectories, integration errors and numbers. Output: systems
(`example_system`), best-of-k runs (`_best_wall`), state errors (`_state`, `_err`), kinetic
energies, failure texts (`_why`) and number formatting for logs and Markdown (`_fmt`, `_ms`,
`_times`, `_table`).

Example:
    >>> _fmt(float("nan")), _ms(0.0123), _table(("a", "b"), [["1", "2"]])
    ('—', '12.3 ms', ['| a | b |', '|---|---|', '| 1 | 2 |'])
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from s2gen import IntegrationError, SpecError, System, Trajectory

Log = Callable[[str], None]


def _print(line: str) -> None:
    print(line, flush=True)


def example_system(name: str) -> System:
    """A TOML spec file or a built-in system by name (with options: ``rope:n=50``; see
    `s2gen.load`), else a factory of `s2gen.paper` of that name.

    Example:
        >>> example_system("double_pendulum").n, example_system("rope:n=50").n
        (2, 50)
    """
    from pathlib import Path

    import s2gen
    from s2gen import paper

    builtin = name.partition(":")[0] in s2gen.builtins()
    if builtin or Path(name).is_file() or name.endswith(".toml"):
        return s2gen.load(name)
    factory = getattr(paper, name, None)
    if name in getattr(paper, "__all__", ()) and callable(factory):
        system = factory()
        if isinstance(system, System):
            return system
    raise SpecError(f"unknown example {name!r}; built-ins are: {', '.join(s2gen.builtins())}")


def _best_wall(run: Callable[[], Trajectory], k: int) -> Trajectory:
    """Run up to k times (fewer when a run is slow); the result carries the best wall time."""
    best = run()
    total = best.wall_time
    for _ in range(k - 1):
        if total > 2.0:
            break
        tr = run()
        total += tr.wall_time
        if tr.wall_time < best.wall_time:
            best = tr
    return best


def _state(tr: Trajectory) -> np.ndarray:
    return np.concatenate([tr.q[-1].ravel(), tr.omega[-1].ravel()])


def _err(q: np.ndarray, w: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(np.concatenate([q.ravel(), w.ravel()]) - ref))


def kinetic_energy(system: System, q: np.ndarray, w: np.ndarray, params: Any = None) -> np.ndarray:
    """1/2 sum_ij M_ij qdot_i . qdot_j with qdot_i = omega_i x q_i, for (..., n, 3) arrays.

    Example:
        >>> s = example_system("double_pendulum")
        >>> float(kinetic_energy(s, s.q0, s.omega0)) > 0
        True
    """
    M = system.inertia_numeric(params)
    qdot = np.cross(w, q)
    return 0.5 * np.einsum("ij,...ic,...jc->...", M, qdot, qdot)


def _why(exc: IntegrationError) -> str:
    reasons = {1: "infeasible", 2: "newton", 3: "non-finite", 5: "step-underflow", 6: "singular"}
    return f"failed ({reasons.get(exc.status, exc.status)} at step {exc.step})"


def _fmt(x: float | None, spec: str = ".3g") -> str:
    if x is None or not np.isfinite(x):
        return "—"
    return format(x, spec)


def _times(ratio: float | None) -> str:
    return _fmt(ratio, ".0f") + "×" if ratio is not None and np.isfinite(ratio) else "—"


def _ms(seconds: float) -> str:
    return _fmt(seconds * 1e3, ".3g") + " ms"


def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return out + ["| " + " | ".join(r) + " |" for r in rows]
