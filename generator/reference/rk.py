"""Fixed-step Runge-Kutta methods on the continuous vector field y = (q, w) in R^{6n}.

Input: a `_Recorder` (problem and flat-state layout), a method name ("rk4", "rk2" or
"rk2-proj") and the step h.
Output: a function advance(y_k, k) -> y_k+1 for `_run_fixed`: classical RK4, the explicit
midpoint rule, or the midpoint rule followed by normalizing each q_i.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s2gen.reference.problem import Array
from s2gen.reference.recorder import _Recorder, _state, _vector_field


def _rk_advance(rec: _Recorder, method: str, h: float) -> Callable[[Array, int], Array]:
    """One step of "rk4" (classical), "rk2" (explicit midpoint) or "rk2-proj"."""
    fun = _vector_field(rec)

    def rk4(y: Array, k: int) -> Array:
        k1 = fun(y)
        k2 = fun(y + 0.5 * h * k1)
        k3 = fun(y + 0.5 * h * k2)
        k4 = fun(y + h * k3)
        return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def rk2(y: Array, k: int) -> Array:
        return y + h * fun(y + 0.5 * h * fun(y))

    def rk2_proj(y: Array, k: int) -> Array:
        y1 = rk2(y, k)
        q, w = rec.split(y1)
        return _state(q / np.linalg.norm(q, axis=1)[:, None], w)

    return {"rk4": rk4, "rk2": rk2, "rk2-proj": rk2_proj}[method]
