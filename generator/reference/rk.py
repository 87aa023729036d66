"""Fixed-step explicit Runge-Kutta methods on the continuous vector field y = (q, w) in R^{6n}.

Input: a `_Recorder` (problem and flat-state layout), a fixed-step method of s2gen.methods
("rk2", "rk2-proj", "rk4", ...) and the step h.
Output: a function advance(y_k, k) -> y_k+1 for `_run_fixed`: one step of the method's Butcher
tableau (the numbers of s2gen.tableaus, stepped here by the textbook formula
k_i = f(y + h sum_j a_ij k_j), y+ = y + h sum_i b_i k_i), followed by normalizing each q_i when
the method projects ("rk2-proj").

Example:
    >>> from s2gen.tableaus import RK4
    >>> step = _explicit_step(lambda y: -y, RK4, 0.1)
    >>> round(float(step(np.array([1.0]))[0]), 10)  # exp(-0.1) to order 4
    0.9048375
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from s2gen.methods import method as method_row
from s2gen.reference.problem import Array
from s2gen.reference.recorder import _Recorder, _state, _vector_field
from s2gen.tableaus import Explicit


def _weighted(weights: Sequence[float], k: Sequence[Array], like: Array) -> Array:
    """sum_j weights[j] k[j] over the non-zero weights (zeros shaped like `like` if none)."""
    out = np.zeros_like(like)
    for w, kj in zip(weights, k):
        if w != 0.0:
            out = out + w * kj
    return out


def _explicit_step(
    fun: Callable[[Array], Array], t: Explicit, h: float
) -> Callable[[Array], Array]:
    """y -> y+ by one step of the tableau `t` of the autonomous field `fun`."""
    a = [[float(x) for x in row] for row in t.a]
    b = [float(x) for x in t.b]

    def step(y: Array) -> Array:
        k: list[Array] = []
        for row in a:
            k.append(fun(y + h * _weighted(row, k, y)))
        return y + h * _weighted(b, k, y)

    return step


def _rk_advance(rec: _Recorder, method: str, h: float) -> Callable[[Array, int], Array]:
    """One step of the fixed-step method `method`, projected if the method says so."""
    row = method_row(method)
    if row.tableau is None:
        raise ValueError(f"{method!r} is not a fixed-step Runge-Kutta method")
    step = _explicit_step(_vector_field(rec), row.tableau, h)

    def advance(y: Array, k: int) -> Array:
        y1 = step(y)
        if not row.project:
            return y1
        q, w = rec.split(y1)
        return _state(q / np.sqrt(np.sum(q * q, axis=1))[:, None], w)  # |q_i|, also complex

    return advance
