"""Lyapunov spectra of a system's discrete flow, from products of exact step Jacobians.

Input: a C or NumPy backend whose module has step_jacobian() (`System.with_jacobians`) or the
reference backend (the complex-step derivative of its own step: slow, a check), an initial
state, a fixed-step method with a step Jacobian, h, the averaging time T and a transient.
Output: a `LyapunovSpectrum`.

The method is Benettin et al.'s (Meccanica 15, 1980) and Shimada and Nagashima's (Prog.
Theor. Phys. 61, 1979): with A_k the derivative of step k in the tangent coordinates of
T(S^2)^n (`s2gen.runtime.linearize`), an orthonormal frame Q of 4n tangent vectors is carried
by Q_(k+1) R_k = qr(A_k Q_k), and lambda_j = (1/T) sum_k log |(R_k)_jj| over the steps after
the transient (during which the frame turns towards the Lyapunov vectors and nothing is
summed). The exponents come out in the order of the frame's columns, which the iteration makes
decreasing as T grows (nearly equal ones, such as the zeros of conserved quantities, may stay
in either order). The frame is kept in the embedding
coordinates (6n x 4n, orthonormal columns spanning the tangent space): each step multiplies it
by the embedding A and projects it on the tangent space after the step (the complement of
(q_i, 0) and (w_i - (w_i . q_i) q_i, q_i), q_i normalized), which is the tangent A of
`linearize`, basis_out^T A basis_in, without building the bases; the first step goes through
`linearize` itself (its checks and errors), the others through step_jacobian() (C: with
buffers prepared once).

The statistical error of each exponent (and of the pair sums lambda_k + lambda_(4n+1-k) and
the total) is the standard error of the means over `blocks` consecutive blocks of equal length,
std / sqrt(blocks): blocks much longer than the correlation time are independent estimates.
The running estimates (the sums so far over the time so far) are kept at `samples` times for
the convergence plot.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.runtime.c import CBackend
    >>> s = builtin("double_pendulum")
    >>> be = CBackend(s.with_jacobians())
    >>> ls = lyapunov(be, s.q0, s.omega0, 0.01, 2.0, "vi", be.default_params(), transient=0.5)
    >>> ls.exponents.shape, ls.running.shape, float(ls.times[-1])
    ((8,), (200, 8), 2.0)
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.methods import Status, method
from s2gen.runtime.c import CBackend, contiguous, pointer
from s2gen.runtime.linearize import linearize
from s2gen.runtime.options import Options

__all__ = ["LyapunovSpectrum", "check_lyapunov", "lyapunov", "tangent_normals"]


@dataclass(frozen=True)
class LyapunovSpectrum:
    """A Lyapunov spectrum: `exponents` (4n, in the frame's order: decreasing, up to nearly
    equal ones) with their standard errors
    (`error`), the pair sums lambda_k + lambda_(4n+1-k) (`pair_sums`, 2n) with theirs
    (`pair_error`), the sum of all (`total`, `total_error`), the running estimates
    (`running`, one row per time of `times`, the averaging time so far), and the run: method,
    h, averaging time T, transient, number of blocks."""

    exponents: np.ndarray
    error: np.ndarray
    pair_sums: np.ndarray
    pair_error: np.ndarray
    total: float
    total_error: float
    times: np.ndarray
    running: np.ndarray
    method: str
    h: float
    T: float
    transient: float
    blocks: int


def tangent_normals(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The orthonormal complement of the tangent space of `tangent_basis(q, w)` in the
    embedding coordinates: shape (6n, 2n), columns 2i, 2i + 1 the normalized (q_i, 0) and
    (w_i - (w_i . q_i) q_i, q_i), q_i normalized.

    Example:
        >>> from s2gen.runtime.linearize import tangent_basis
        >>> q = np.array([[0.0, 0.6, -0.8]]); w = np.array([[1.0, 0.8, 0.6]])
        >>> N = tangent_normals(q, w)
        >>> bool(np.allclose(np.hstack([N, tangent_basis(q, w)]).T @ np.hstack([N, tangent_basis(q, w)]), np.eye(6)))
        True
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w = np.asarray(w, dtype=float)
    n = len(q)
    wt = w - np.einsum("ia,ia->i", w, q)[:, None] * q
    s = 1.0 / np.sqrt(1.0 + np.einsum("ia,ia->i", wt, wt))[:, None]
    out = np.zeros((6 * n, 2 * n))
    view, i = out.reshape(2, n, 3, n, 2), np.arange(n)  # (q or w, body, xyz, body, column)
    view[0, i, :, i, 0] = q
    view[0, i, :, i, 1] = wt * s
    view[1, i, :, i, 1] = q * s
    return out


def _steps(total: int, blocks: int) -> np.ndarray:
    """The first step of each of `blocks` blocks of `total` steps, and `total`."""
    return np.array([total * b // blocks for b in range(blocks + 1)])


def check_lyapunov(
    h: float, T: float, transient: float, blocks: int, samples: int
) -> tuple[int, int]:
    """The steps of the averaging time T and of the transient (ValueError for bad input).

    Example:
        >>> check_lyapunov(0.01, 1.0, 0.1, 10, 100)
        (100, 10)
    """
    for name, value in (("h", h), ("T", T), ("transient", transient)):
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"{name} = {value!r}: must be a finite number")
    if h <= 0 or T <= 0 or transient < 0:
        bad = "h" if h <= 0 else ("T" if T <= 0 else "transient")
        raise ValueError(f"{bad} = {locals()[bad]!r}: must be positive")
    if not isinstance(blocks, int) or blocks < 2:
        raise ValueError(f"blocks = {blocks!r}: must be an integer of at least 2")
    if not isinstance(samples, int) or samples < 1:
        raise ValueError(f"samples = {samples!r}: must be a positive integer")
    steps = round(T / h)
    if steps < blocks:
        raise ValueError(f"T = {T!r} is {steps} steps of h = {h!r}: fewer than {blocks} blocks")
    return steps, round(transient / h)


def lyapunov(
    backend: Any,
    q: np.ndarray,
    w: np.ndarray,
    h: float,
    T: float,
    method_name: str,
    params: np.ndarray,
    transient: float = 0.0,
    t0: float = 0.0,
    u: np.ndarray | None = None,
    blocks: int = 10,
    samples: int = 400,
    options: Options | None = None,
    progress: Callable[[float], None] | None = None,
) -> LyapunovSpectrum:
    """The `LyapunovSpectrum` of `method_name`'s steps of size h from (q, w) (shape (n, 3))
    at time t0 with the inputs u held (None: the spec's defaults) on a `CBackend` or
    `NumpyBackend` with step_jacobian() or the reference backend: `transient` (rounded to
    steps) discarded, then T averaged in `blocks` blocks, the running estimates at `samples`
    times; `progress(fraction)` is called about a hundred times. ValueError for bad input or
    a failed step (named by its time).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.runtime.c import CBackend
        >>> s = builtin("double_pendulum")
        >>> be = CBackend(s.with_jacobians())
        >>> lyapunov(be, s.q0, s.omega0, 0.01, 0.1, "rk4", be.default_params(), blocks=5).T
        0.1
    """
    steps, skip = check_lyapunov(h, T, transient, blocks, samples)
    system = backend.system
    n, ni = system.n, len(system.inputs.names)
    opts = Options() if options is None else options
    uu = None if u is None else contiguous(np.asarray(u, dtype=float).reshape(ni))
    first = linearize(backend, q, w, h, method_name, params, t0, uu, "embedding", opts)
    Q = first.basis_in
    A = contiguous(first.A)
    qa, wa = contiguous(first.q), contiguous(first.omega)
    advance = _advance(backend, method_name, params, uu, opts)
    total = skip + steps
    edges = _steps(steps, blocks)
    record = set(_steps(steps, samples)[1:].tolist())
    tick = max(1, total // 100)
    sums = np.zeros((blocks, 4 * n))
    running, times = [], []
    for k in range(total):
        if k > 0:
            status, qa, wa, A = advance(t0 + k * h, h, qa, wa)
            if status != 0:
                st = Status(status)
                raise ValueError(
                    f"{system.name}: step_jacobian at t = {t0 + k * h:.6g}: {st.c_name}: "
                    f"{st.message}"
                )
        N = tangent_normals(qa, wa)
        Y = A @ Q
        Y -= N @ (N.T @ Y)
        Q, R = np.linalg.qr(Y)
        if k >= skip:
            done = k - skip
            sums[np.searchsorted(edges, done, side="right") - 1] += np.log(np.abs(np.diag(R)))
            if done + 1 in record:
                times.append((done + 1) * h)
                running.append(sums.sum(axis=0) / times[-1])
        if progress is not None and (k + 1) % tick == 0:
            progress((k + 1) / total)
    return _spectrum(sums, edges, h, np.array(times), np.array(running), method_name, transient)


def _advance(
    backend: Any, method_name: str, params: np.ndarray, u: np.ndarray | None, opts: Options
) -> Callable[[float, float, np.ndarray, np.ndarray], tuple[Any, ...]]:
    """The step of `lyapunov`'s loop: (t, h, q, w) -> (status, qn, wn, A), A in the embedding
    coordinates; on the C backend one call of step_jacobian() into buffers prepared once (two
    state buffers used in turn), on the NumPy backend one call of the module's, on the
    reference backend its complex-step A (`ReferenceBackend.state_jacobian`, no B or P)."""
    code = method(method_name).code
    if backend.name == "reference":
        p_ref = np.asarray(params, dtype=float)

        def reference_step(t: float, h: float, q: np.ndarray, w: np.ndarray) -> tuple[Any, ...]:
            try:
                return (0, *backend.state_jacobian(method_name, t, h, q, w, u, p_ref, opts))
            except ValueError as exc:  # it names the status; the time is the loop's
                raise ValueError(f"{exc} (the step at t = {t:.6g})") from exc

        return reference_step
    if not isinstance(backend, CBackend):
        fun, p = backend.module.step_jacobian, np.asarray(params, dtype=float)

        def numpy_step(t: float, h: float, q: np.ndarray, w: np.ndarray) -> tuple[Any, ...]:
            tol, most = opts.newton_tol, opts.newton_maxiter
            return tuple(fun(p, code, t, h, q, w, u, tol, most)[:4])

        return numpy_step
    n = backend.system.n
    buffers = [(np.empty((n, 3)), np.empty((n, 3))) for _ in range(2)]
    A = np.empty((6 * n, 6 * n))
    work = np.zeros(backend.library.jacobian_work)
    fn = backend.library.fn["step_jacobian"]
    opt, pc, up = ctypes.byref(backend.library.options(opts)), contiguous(params), pointer(u)

    def c_step(t: float, h: float, q: np.ndarray, w: np.ndarray) -> tuple[Any, ...]:
        qb, wb = buffers[0]
        buffers.reverse()
        status = fn(pc, opt, code, t, h, up, q, w, qb, wb, A, None, None, work)
        return status, qb, wb, A

    return c_step


def _spectrum(
    sums: np.ndarray,
    edges: np.ndarray,
    h: float,
    times: np.ndarray,
    running: np.ndarray,
    method_name: str,
    transient: float,
) -> LyapunovSpectrum:
    """The record from the blocks' sums of log |R_jj| (one row per block)."""
    blocks, dim = sums.shape
    lengths = np.diff(edges) * h
    means = sums / lengths[:, None]
    T = float(lengths.sum())
    exponents = sums.sum(axis=0) / T
    pairs = means[:, : dim // 2] + means[:, ::-1][:, : dim // 2]

    def error(x: np.ndarray) -> np.ndarray:
        return np.asarray(x.std(axis=0, ddof=1) / np.sqrt(blocks))

    return LyapunovSpectrum(
        exponents=exponents,
        error=error(means),
        pair_sums=exponents[: dim // 2] + exponents[::-1][: dim // 2],
        pair_error=error(pairs),
        total=float(exponents.sum()),
        total_error=float(error(means.sum(axis=1, keepdims=True))[0]),
        times=times,
        running=running,
        method=method_name,
        h=h,
        T=T,
        transient=transient,
        blocks=blocks,
    )
