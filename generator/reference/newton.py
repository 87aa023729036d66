"""Newton's method as the reference's implicit steps use it: one loop, one stopping rule.

Input: a start x0 and a function giving (residual, Jacobian) at x; the tolerance, iteration
limit, the step (for messages) and what is being solved (for messages). Output: (x, iterations)
with max |update| <= tol max(1, max |x|) (real parts: a complex iterate, carried for a
complex-step derivative, takes the iterations of its real part), or `NewtonFailure` after `maxiter` iterations, on a
non-finite iterate or a singular Jacobian. The VI's Cayley parameters, the forced VI's
velocity update and RATTLE's multipliers are solved by it.

Example:
    >>> import numpy as np
    >>> x, its = newton(np.array([1.0]), lambda x: (x * x - 2.0, np.diag(2.0 * x)), 1e-14, 50,
    ...                 0, "square root")
    >>> round(float(x[0]), 15), its
    (1.414213562373095, 6)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s2gen.reference.errors import NewtonFailure
from s2gen.reference.problem import Array

__all__ = ["newton"]


def newton(
    x0: Array,
    linearize: Callable[[Array], tuple[Array, Array]],
    tol: float,
    maxiter: int,
    step: int,
    what: str,
) -> tuple[Array, int]:
    """Solve r(x) = 0 from x0, `linearize(x)` giving (r(x), dr/dx as a matrix on x.ravel())."""
    x = x0
    for it in range(1, maxiter + 1):
        r, jacobian = linearize(x)
        try:
            delta = np.linalg.solve(jacobian, -r.ravel()).reshape(x.shape)
        except np.linalg.LinAlgError as exc:
            raise NewtonFailure(
                step, f"{what}: singular Jacobian at iteration {it} ({exc})"
            ) from exc
        x = x + delta
        if not np.all(np.isfinite(x)):
            raise NewtonFailure(step, f"{what}: iterate not finite at iteration {it}")
        # the real parts decide (a complex-step iterate stops when its real part would)
        if np.max(np.abs(delta.real)) <= tol * max(1.0, float(np.max(np.abs(x.real)))):
            return x, it
    raise NewtonFailure(step, f"{what} did not converge in {maxiter} iterations")
