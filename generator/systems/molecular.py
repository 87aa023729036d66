"""The paper's example 6: Lennard-Jones molecules on an icosphere, and the pieces it is made
of (sigma from a distance, vortex initial velocities, the all-pairs Lennard-Jones system).

Input: the mesh's subdivisions and the vortices' shape (keyword arguments with documented
defaults). Output: a validated `System` with one all-pairs (or cutoff) pair term. Part of
`s2gen.paper` (re-exported there).

Example:
    >>> molecular(subdivisions=1).n
    42
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from s2gen.symbols import vector
from s2gen.system import RunSettings, System, Term
from s2gen.systems.meshes import icosphere, nearest_neighbour_distance
from s2gen.terms import TermKind

__all__ = [
    "lennard_jones_sigma",
    "lennard_jones_system",
    "molecular",
    "vortex_axes",
    "vortex_velocities",
]

_ORIGIN = "s2gen.systems.paper"


def _sym(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


def _deg(angle: float) -> float:
    return math.radians(angle)


def lennard_jones_sigma(distance: float) -> float:
    """The sigma whose Lennard-Jones force vanishes at `distance` (minimum at 2^(1/6) sigma).

    Example:
        >>> round(lennard_jones_sigma(2 ** (1 / 6)), 12)
        1.0
    """
    return distance / 2 ** (1 / 6)


def vortex_velocities(
    q: np.ndarray,
    axes: np.ndarray,
    rates: tuple[float, ...],
    width: float,
) -> np.ndarray:
    """Angular velocities (n, 3), tangent to q, of vortices: rigid rotation about each axis a_k
    at rate rates[k], weighted by exp(-theta^2 / (2 width^2)), theta the angle from a_k.

    Rotation about a moves q with velocity rate (a x q); the tangent angular velocity with
    that motion (dq/dt = omega x q) is rate (a - (a.q) q).

    Example:
        >>> q = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        >>> vortex_velocities(q, np.array([[0.0, 0.0, 1.0]]), (2.0,), 10.0).round(3).tolist()
        [[0.0, 0.0, 1.975], [0.0, 0.0, 0.0]]
    """
    omega = np.zeros_like(q, dtype=float)
    for a, rate in zip(np.asarray(axes, dtype=float), rates):
        cos = np.clip(q @ a, -1.0, 1.0)
        weight = rate * np.exp(-(np.arccos(cos) ** 2) / (2 * width**2))
        omega += weight[:, None] * (a[None, :] - cos[:, None] * q)
    radial = np.einsum("ij,ij->i", omega, q)
    return omega - radial[:, None] * q


def vortex_axes(separation_deg: float = 30.0) -> np.ndarray:
    """Two unit axes in the x-z plane, symmetric about e3, `separation_deg` apart.

    Example:
        >>> a = vortex_axes(30.0)
        >>> round(math.degrees(math.acos(a[0] @ a[1])), 9)
        30.0
    """
    half = _deg(separation_deg / 2)
    return np.array([[-math.sin(half), 0.0, math.cos(half)], [math.sin(half), 0.0, math.cos(half)]])


def molecular(
    subdivisions: int = 3,
    sigma: str | float = "nearest",
    rate: float = 4.0,
    width_deg: float = 15.0,
    separation_deg: float = 30.0,
    sense: str = "same",
) -> System:
    """Lennard-Jones particles at the vertices of an icosphere (paper, example 6: 642).

    m_i = 1, epsilon = 0.01; sigma puts the force zero at the mean nearest-neighbour distance
    ("nearest"; "edge": at the mean mesh-edge length; or a number). Initial velocities: two
    Gaussian vortices (`vortex_velocities`, angular width `width_deg`, rate `rate` rad/s)
    about axes `separation_deg` apart, turning the same way ("same") or opposite ("opposite").
    The paper gives neither sigma nor the field; the default rate was tuned so the VI energy
    figure lands near the printed one (docs/paper-setup.md).

    Example:
        >>> s = molecular(subdivisions=1)
        >>> s.n, round(s.parameters["sigma"], 4)
        (42, 0.4869)
    """
    v, faces = icosphere(subdivisions)
    if sigma not in ("nearest", "edge") and not isinstance(sigma, (int, float)):
        raise ValueError(f"sigma must be 'nearest', 'edge' or a number, got {sigma!r}")
    sig = (
        lennard_jones_sigma(nearest_neighbour_distance(v, faces if sigma == "edge" else None))
        if isinstance(sigma, str)
        else float(sigma)
    )
    if sense not in ("same", "opposite"):
        raise ValueError(f"sense must be 'same' or 'opposite', got {sense!r}")
    rates = (rate, rate if sense == "same" else -rate)
    omega0 = vortex_velocities(v, vortex_axes(separation_deg), rates, _deg(width_deg))
    return lennard_jones_system(
        "molecular",
        v,
        omega0,
        sig,
        RunSettings(h=0.005, T=5.0, method="vi"),
        f"{_ORIGIN}.molecular(subdivisions={subdivisions}, sigma={sigma!r}, "
        f"rate={rate}, width_deg={width_deg}, separation_deg={separation_deg}, sense={sense!r})",
    )


def lennard_jones_system(
    name: str,
    q0: np.ndarray,
    omega0: np.ndarray,
    sigma: float,
    run: RunSettings,
    origin: str,
    cutoff: float | None = None,
) -> System:
    """Unit masses on the sphere under 4 eps ((sigma/r)^12 - (sigma/r)^6) over all pairs
    (eps = 0.01, r the chord |q_i - q_j|), optionally only pairs closer than `cutoff`.

    Example:
        >>> v, _ = icosphere(1)
        >>> lennard_jones_system("lj", v, 0 * v, 0.5, RunSettings(), "doc").n
        42
    """
    m, eps, sg = _sym("m"), _sym("eps"), _sym("sigma")
    d = vector("qi") - vector("qj")
    s6 = (sg**2 / d.dot(d)) ** 3
    lj = Term(TermKind.PAIR, 4 * eps * (s6**2 - s6), label="Lennard-Jones", cutoff=cutoff)
    n = len(q0)
    return System.create(
        name=name,
        n=n,
        parameters={"m": 1.0, "eps": 0.01, "sigma": sigma},
        inertia=sp.ImmutableSparseMatrix(n, n, {(i, i): m for i in range(n)}),
        potential=sp.Integer(0),
        q0=q0,
        omega0=omega0,
        run=run,
        origin=origin,
        terms=[lj],
    )
