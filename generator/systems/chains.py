"""Chains of spherical pendula: the rope, with M given per body (O(n) solves, any n).

Input: the number of links and the rope's make-up (keyword arguments with defaults).
Output: a validated `System` whose inertia is a `ChainInertia` (diagonal plus max-index: never
n^2 entries) and whose potential is structured terms (gravity per body, bending springs on
the chain), so generation time and code size do not grow with n (data tables aside).

Link k (1-based, from the pinned end) has length l_k and carries a point mass m_k at its far
end; link 1 hangs from a fixed pivot at the origin, q_k points along link k. The mass k sits
at r_k = sum_{i <= k} l_i q_i, so with T_i = sum_{k >= i} m_k (the mass below joint i)
    T = 1/2 sum_ij l_i l_j T_max(i,j) qdot_i . qdot_j,   V = g sum_i l_i T_i e3 . q_i,
that is M_ii = l_i^2 T_i and M_ij = l_i l_j T_max(i,j): scale l, max_index T, and the diagonal
remainder M_ii - l_i^2 T_i is exactly 0 (point masses; the structured solve pivots).

Example:
    >>> s = rope(4)
    >>> s.n, s.structure.kind.value, [t.label for t in s.terms]
    (4, 'max-index', ['gravity', 'bending springs'])
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import sympy as sp

from s2gen.inertia import ChainInertia
from s2gen.symbols import vector
from s2gen.system import INERTIA_SOLVERS, MAX_BODIES, RunSettings, System, Term, TermData
from s2gen.terms import TermKind

__all__ = ["default_step", "rope"]

_ORIGIN = "s2gen.systems.chains"


def _fractions(values: Sequence[float] | None, n: int, what: str) -> np.ndarray:
    """Per-link shares of a total (positive, normalized to sum 1); uniform when None."""
    if values is None:
        return np.full(n, 1.0 / n)
    out = np.asarray(values, dtype=float)
    if out.shape != (n,) or not np.all(np.isfinite(out)) or not np.all(out > 0):
        raise ValueError(f"rope: {what} must be {n} positive numbers, got {values!r}")
    return out / out.sum()


def default_step(
    mu: np.ndarray, lam: np.ndarray, mass: float, length: float, kappa: float
) -> float:
    """A step that resolves the rope's fastest motion: 1/omega_max, rounded down to 1, 2 or 5
    times a power of ten, at most 1e-3. omega_max is the larger of the tension wave
    2 max_i sqrt(g T_i / (m_i l_i)) (T_i the mass below joint i) and the bending zigzag
    4 sqrt(kappa / min_i m_i l_i^2); both grow with n (like n and n^1.5 for a uniform rope).

    Example:
        >>> default_step(np.full(200, 1 / 200), np.full(200, 1 / 200), 1.0, 1.0, 0.05)
        0.0002
    """
    m, l = mass * mu, length * lam
    tail = np.cumsum(m[::-1])[::-1]
    tension = 2.0 * float(np.max(np.sqrt(9.81 * tail / (m * l))))
    bending = 4.0 * math.sqrt(kappa / float(np.min(m * l * l))) if kappa > 0 else 0.0
    h = min(1e-3, 1.0 / max(tension, bending))
    power = 10.0 ** math.floor(math.log10(h))
    return max(f for f in (power, 2 * power, 5 * power) if f <= h * (1 + 1e-12))


def rope(
    n: int = 20,
    mass: float = 1.0,
    length: float = 1.0,
    kappa: float = 0.05,
    angle_deg: float = 60.0,
    masses: Sequence[float] | None = None,
    lengths: Sequence[float] | None = None,
    solver: str = "auto",
    top_radius: float = 0.0,
    top_rate: float = 3.0,
) -> System:
    """A rope: n spherical pendula in a chain, the first pinned at the origin (see above).

    Total `mass` (kg) and `length` (m) are parameters m and L of the emitted code; `masses`
    and `lengths` give the links' shares (uniform by default; normalized). Neighbouring links
    are joined by bending springs kappa (1 - q_i . q_i+1) (N m, parameter kappa); gravity g =
    9.81 m/s^2 along -e3. The rope starts straight, `angle_deg` from the downward vertical in
    the e1-e3 plane, at rest; the default step resolves its fastest motion (`default_step`:
    1e-3 up to n = 50, 2e-4 at n = 200, 2e-5 at n = 1000). `solver` ("auto", "dense",
    "structured") chooses the coupled solves.

    With `top_radius` R > 0 the top moves: it runs round the horizontal circle
    R (cos W t, sin W t, 0), W = `top_rate` rad/s (parameters R and W), and the rope is
    written in the top's frame, where every mass m_k feels the inertial force -m_k a(t) of
    the top's acceleration a(t) = -R W^2 (cos W t, sin W t, 0): gravity's term becomes
    m L w_k (g q_k[2] + a(t) . q_k), a time-dependent potential (a driven system).

    Example:
        >>> s = rope(3, masses=[1, 1, 2])
        >>> s.inertia_numeric().round(4).tolist()
        [[0.1111, 0.0833, 0.0556], [0.0833, 0.0833, 0.0556], [0.0556, 0.0556, 0.0556]]
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"rope: n must be a positive integer, got {n!r}")
    if n > MAX_BODIES:  # checked before any body is made
        raise ValueError(f"n={n} bodies is more than the limit of {MAX_BODIES}")
    if solver not in INERTIA_SOLVERS:
        raise ValueError(f"rope: solver must be one of {INERTIA_SOLVERS}, got {solver!r}")
    mu = _fractions(masses, n, "masses")
    lam = _fractions(lengths, n, "lengths")
    tail = np.cumsum(mu[::-1])[::-1]  # share of the mass below each joint
    m, L, g, kappa_s = (sp.Symbol(s, real=True) for s in ("m", "L", "g", "kappa"))
    lam_s, tail_s, w_s = (sp.Symbol(s, real=True) for s in ("lam", "tail", "w"))
    inertia = ChainInertia(
        diagonal=m * L**2 * lam_s**2 * tail_s,
        max_index=m * L**2 * tail_s,
        scale=lam_s,
        data=(TermData("lam", 1, tuple(lam)), TermData("tail", 1, tuple(tail))),
    )
    q, qi, qj = vector("q"), vector("qi"), vector("qj")
    field = g * q[2]
    extra: dict[str, float] = {}
    if top_radius:
        if not (math.isfinite(top_radius) and top_radius > 0 and math.isfinite(top_rate)):
            raise ValueError(f"rope: top_radius must be a positive number, got {top_radius!r}")
        R, W = sp.Symbol("R", real=True), sp.Symbol("W", real=True)
        t = sp.Symbol("t", real=True)
        field -= R * W**2 * (sp.cos(W * t) * q[0] + sp.sin(W * t) * q[1])
        extra = {"R": float(top_radius), "W": float(top_rate)}
    gravity = Term(
        TermKind.BODY,
        m * L * w_s * field,
        data=(TermData("w", 1, tuple(lam * tail)),),
        label="gravity" if not top_radius else "gravity and the moving top",
    )
    bending = Term(
        TermKind.PAIR, kappa_s * (1 - qi.dot(qj)), select="chain", label="bending springs"
    )
    angle = math.radians(angle_deg)
    q0 = np.tile([math.sin(angle), 0.0, -math.cos(angle)], (n, 1))
    options = f"n={n}" + ("" if solver == "auto" else f", solver={solver!r}")
    options += f", top_radius={top_radius!r}, top_rate={top_rate!r}" if top_radius else ""
    return System.create(
        name="rope",
        n=n,
        parameters={
            "m": float(mass),
            "L": float(length),
            "g": 9.81,
            "kappa": float(kappa),
            **extra,
        },
        inertia=inertia,
        potential=sp.Integer(0),
        q0=q0,
        omega0=np.zeros((n, 3)),
        run=RunSettings(h=default_step(mu, lam, mass, length, kappa), T=2.0, method="vi"),
        origin=f"{_ORIGIN}.rope({options})",
        terms=[gravity] + ([bending] if n > 1 else []),
        inertia_solver=solver,
    )
