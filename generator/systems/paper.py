"""The paper's numerical examples 2-6 as Python factories (example 1 is a TOML file).

Input: a few choices the paper leaves open (keyword arguments with documented defaults).
Output: validated systems (`System`) whose pair and one-body interactions are structured terms
(`Term`), so code generation emits each interaction once as a kernel plus a loop over its
members.

Lee, Leok & McClamroch, "Lagrangian mechanics and variational integrators on two-spheres",
section 3.5. Initial vectors are the exact unit vectors the printed 4-digit values round; see
docs/paper-setup.md for every choice and its effect on the printed figures.

Example:
    >>> three_bodies().n, four_pendula().n, elastic_rod().n, dipoles().n
    (3, 4, 10, 16)
    >>> icosphere(3)[0].shape
    (642, 3)
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from s2gen.inertia import INDEX, ChainInertia
from s2gen.symbols import vector
from s2gen.system import INERTIA_SOLVERS, MAX_BODIES, RunSettings, System, Term, TermData
from s2gen.systems.meshes import icosphere, nearest_neighbour_distance
from s2gen.systems.molecular import (
    lennard_jones_sigma,
    lennard_jones_system,
    molecular,
    vortex_axes,
    vortex_velocities,
)
from s2gen.terms import TermKind

__all__ = [
    "DIPOLE_NUMBERINGS",
    "DIPOLE_PLANES",
    "ROD_INERTIA",
    "dipole_grid",
    "dipoles",
    "elastic_rod",
    "four_pendula",
    "icosphere",
    "lennard_jones_sigma",
    "lennard_jones_system",
    "molecular",
    "nearest_neighbour_distance",
    "rod_chain_inertia",
    "rod_inertia",
    "three_bodies",
    "vortex_axes",
    "vortex_velocities",
]

_ORIGIN = "s2gen.systems.paper"
ROD_INERTIA = ("paper", "physical")


def _sym(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


def _deg(angle: float) -> float:
    return math.radians(angle)


# ------------------------------------------------------------------------- n bodies on a sphere
def three_bodies() -> System:
    """Three unit masses on the unit sphere with the cotangent potential (paper, example 2).

    V = -gamma/2 sum_{i != j} qi.qj / sqrt(1 - (qi.qj)^2), one "all" pair term.

    Example:
        >>> s = three_bodies()
        >>> s.parameters, s.terms[0].count(3)
        ({'m': 1.0, 'gamma': 1.0}, 3)
    """
    m, gamma = _sym("m"), _sym("gamma")
    c = vector("qi").dot(vector("qj"))
    term = Term(TermKind.PAIR, -gamma * c / sp.sqrt(1 - c**2), label="cotangent attraction")
    return System.create(
        name="three_bodies",
        n=3,
        parameters={"m": 1.0, "gamma": 1.0},
        inertia=m * sp.eye(3),
        potential=sp.Integer(0),
        q0=[[0, -1, 0], [0, 0, 1], [-1, 0, 0]],
        omega0=[[0, 0, -1.1], [1, 0, 0], [0, 1, 0]],
        run=RunSettings(h=1e-3, T=10.0, method="vi"),
        origin=f"{_ORIGIN}.three_bodies",
        terms=[term],
    )


# ------------------------------------------------------------------------- coupled pendula
def four_pendula() -> System:
    """Four spherical pendula on a square of pivots, coupled by springs (paper, example 3).

    Pivots at the corners of a square of side l (r12 = -r34 = l e1, r23 = -r41 = -l e2),
    springs at the link midpoints with constants 10, 20, 30, 40 N/m for the pairs (1,2),
    (2,3), (3,4), (4,1); gravity along e3.

    Example:
        >>> s = four_pendula()
        >>> [t.label for t in s.terms], s.terms[1].members
        (['gravity', 'midpoint springs'], ((0, 1), (1, 2), (2, 3), (3, 0)))
    """
    m, l, g, kappa = _sym("m"), _sym("l"), _sym("g"), _sym("kappa")
    q, qi, qj, r = vector("q"), vector("qi"), vector("qj"), vector("r")
    gravity = Term(TermKind.BODY, -m * g * l * q[2], label="gravity")
    stretch = sp.sqrt((l * r + l / 2 * (qj - qi)).dot(l * r + l / 2 * (qj - qi))) - l * sp.sqrt(
        r.dot(r)
    )
    offsets = ((1, 0, 0), (0, -1, 0), (-1, 0, 0), (0, 1, 0))  # r_ij in units of l
    springs = Term(
        TermKind.PAIR,
        kappa / 2 * stretch**2,
        select="list",
        members=((0, 1), (1, 2), (2, 3), (3, 0)),
        data=(
            TermData("kappa", 1, (10.0, 20.0, 30.0, 40.0)),
            TermData("r", 3, tuple(float(x) for v in offsets for x in v)),
        ),
        label="midpoint springs",
    )
    q3 = (math.cos(_deg(20)) / 2, math.sin(_deg(20)) / 2, math.sqrt(3) / 2)  # printed rounded
    return System.create(
        name="four_pendula",
        n=4,
        parameters={"m": 0.1, "l": 0.1, "g": 9.81},
        inertia=m * l**2 * sp.eye(4),
        potential=sp.Integer(0),
        q0=[[0, 0, 1], [0, 0, 1], q3, [0, 0, 1]],
        omega0=[[-10, 4, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]],
        run=RunSettings(h=0.005, T=30.0, method="vi"),
        origin=f"{_ORIGIN}.four_pendula",
        terms=[gravity, springs],
    )


# ------------------------------------------------------------------------- elastic rod
def rod_inertia(n: int, inertia: str = "paper") -> sp.Matrix:
    """The rod's n x n inertia matrix in units of m l^2 / (n + 1)^3 (equal elements).

    "paper": M_ii = 1/3 + (n - i), M_ij = (n - max(i, j) + 1)/2 as printed; "physical": the
    chain's kinetic energy, M_ii the same, M_ij = n - max(i, j) + 1/2 (i != j).

    Example:
        >>> rod_inertia(3).tolist()
        [[7/3, 1, 1/2], [1, 4/3, 1/2], [1/2, 1/2, 1/3]]
        >>> rod_inertia(3, "physical")[0, 1]
        3/2
    """
    if inertia not in ROD_INERTIA:
        raise ValueError(f"rod inertia must be one of {ROD_INERTIA}, got {inertia!r}")
    half = sp.Rational(1, 2)

    def entry(i: int, j: int) -> sp.Expr:
        if i == j:
            return sp.Rational(1, 3) + (n - i)
        k = max(i, j)
        return half * (n - k + 1) if inertia == "paper" else n - k + half

    return sp.Matrix(n, n, lambda r, c: entry(r + 1, c + 1))


def rod_chain_inertia(n: int, inertia: str = "paper", unit: sp.Expr | None = None) -> ChainInertia:
    """`rod_inertia` per body (times `unit`): M_ii = 1/3 + (n - i) and M_ij = c_max(i,j) with
    c_k = (n - k + 1)/2 ("paper") or n - k + 1/2 ("physical"); three expressions in the body
    index, whatever n.

    Example:
        >>> rod_chain_inertia(3).matrix(3) == rod_inertia(3)
        True
    """
    if inertia not in ROD_INERTIA:
        raise ValueError(f"rod inertia must be one of {ROD_INERTIA}, got {inertia!r}")
    half, u = sp.Rational(1, 2), sp.Integer(1) if unit is None else unit
    tail = half * (n - INDEX + 1) if inertia == "paper" else n - INDEX + half
    return ChainInertia(u * (sp.Rational(1, 3) + n - INDEX), u * tail)


def elastic_rod(n: int = 10, inertia: str = "paper", solver: str = "auto") -> System:
    """Pure bending of a clamped elastic rod of n + 1 rigid elements (paper, example 4).

    Element 0 is clamped along e1; elements 1..n move. Total mass m = 55 g and length
    l = 1.1 m split equally; bending springs kappa = 1000 N m at every joint; gravity along e3.
    The kick omega = [0, 0, 10] goes to element 5 (element n when n < 5). M is given per body
    (`rod_chain_inertia`: diagonal plus max-index, O(n) solves); `solver` ("auto", "dense",
    "structured") chooses the coupled solves.

    Example:
        >>> s = elastic_rod(4, inertia="physical")
        >>> s.n, s.is_diagonal, [t.label for t in s.terms]
        (4, False, ['gravity', 'clamp spring', 'bending springs'])
    """
    if solver not in INERTIA_SOLVERS:
        raise ValueError(f"solver must be one of {INERTIA_SOLVERS}, got {solver!r}")
    if n > MAX_BODIES:  # checked before any body is made
        raise ValueError(f"n={n} bodies is more than the limit of {MAX_BODIES}")
    m, l, g, kappa = _sym("m"), _sym("l"), _sym("g"), _sym("kappa")
    q, qi, qj, w, clamp = vector("q"), vector("qi"), vector("qj"), _sym("w"), vector("clamp")
    # sum_i m_i g (sum_{j<i} l_j q_j + l_i q_i / 2).e3 = m g l/(n+1)^2 sum_j (n - j + 1/2) q_j.e3
    gravity = Term(
        TermKind.BODY,
        -m * g * l / (n + 1) ** 2 * w * q[2],
        data=(TermData("w", 1, tuple(n - j + 0.5 for j in range(1, n + 1))),),
        label="gravity",
    )
    first = Term(
        TermKind.BODY,
        kappa / 2 * (1 - clamp.dot(q)) ** 2,
        select="list",
        members=((0,),),
        data=(TermData("clamp", 3, (1.0, 0.0, 0.0)),),
        label="clamp spring",
    )
    bending = Term(
        TermKind.PAIR, kappa / 2 * (1 - qi.dot(qj)) ** 2, select="chain", label="bending springs"
    )
    omega0 = np.zeros((n, 3))
    omega0[min(5, n) - 1] = (0.0, 0.0, 10.0)
    return System.create(
        name="elastic_rod" if inertia == "paper" else "elastic_rod_physical",
        n=n,
        parameters={"m": 0.055, "l": 1.1, "g": 9.81, "kappa": 1000.0},
        inertia=rod_chain_inertia(n, inertia, m * l**2 / (n + 1) ** 3),
        potential=sp.Integer(0),
        q0=np.tile([1.0, 0.0, 0.0], (n, 1)),
        omega0=omega0,
        run=RunSettings(h=1e-4, T=3.0, method="vi"),
        origin=f"{_ORIGIN}.elastic_rod(n={n}, inertia={inertia!r}"
        + (f", solver={solver!r})" if solver != "auto" else ")"),
        terms=[gravity, first] + ([bending] if n > 1 else []),
        inertia_solver=solver,
    )


# ------------------------------------------------------------------------- magnetic dipoles
DIPOLE_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
DIPOLE_NUMBERINGS = ("row", "column", "snake")


def dipole_grid(plane: str = "xy", numbering: str = "row", side: int = 4) -> np.ndarray:
    """Pivot positions of a side x side grid in units of the spacing, shape (side^2, 3).

    `plane` names the two axes the grid spans ("xy", "xz", "yz"); `numbering` "row" runs
    along the first axis first, "column" along the second, "snake" is row-major with every
    other row reversed.

    Example:
        >>> dipole_grid(side=2).tolist()
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]
        >>> dipole_grid("xz", "column", side=2)[1].tolist()
        [0.0, 0.0, 1.0]
    """
    if plane not in DIPOLE_PLANES or numbering not in DIPOLE_NUMBERINGS:
        raise ValueError(
            f"plane must be one of {sorted(DIPOLE_PLANES)} and numbering one of "
            f"{DIPOLE_NUMBERINGS}, got {plane!r}, {numbering!r}"
        )
    a, b = DIPOLE_PLANES[plane]
    out = np.zeros((side * side, 3))
    for k in range(side * side):
        row, col = divmod(k, side)
        if numbering == "snake" and row % 2:
            col = side - 1 - col
        u, v = (row, col) if numbering == "column" else (col, row)
        out[k, a], out[k, b] = u, v
    return out


def dipoles(plane: str = "xy", numbering: str = "row") -> System:
    """A 4 x 4 grid of magnetic dipoles (spherical compasses) at spacing 1.2 l (example 5).

    V = sum_{i<j} mu nu^2 / (4 pi |r|^3) [qi.qj - 3 (qi.r)(qj.r)/|r|^2], r = r_ij, one "list"
    pair term over all 120 pairs with r_ij in grid units as data. See `dipole_grid` for
    `plane` and `numbering` (the paper gives neither).

    Example:
        >>> s = dipoles()
        >>> s.terms[0].count(16), s.q0[15].round(4).tolist()
        (120, [0.3536, 0.3536, -0.866])
    """
    m, l, nu, mu = _sym("m"), _sym("l"), _sym("nu"), _sym("mu")
    qi, qj, r = vector("qi"), vector("qj"), vector("r")
    dist2 = r.dot(r) * (sp.Rational(6, 5) * l) ** 2
    rr = sp.Rational(6, 5) * l * r  # r_ij in metres
    energy = (
        mu
        * nu**2
        / (4 * sp.pi * dist2 ** sp.Rational(3, 2))
        * (qi.dot(qj) - 3 * qi.dot(rr) * qj.dot(rr) / dist2)
    )
    pos = dipole_grid(plane, numbering)
    pairs = tuple((i, j) for i in range(16) for j in range(i + 1, 16))
    offsets = tuple(float(x) for i, j in pairs for x in pos[j] - pos[i])
    term = Term(
        TermKind.PAIR,
        energy,
        select="list",
        members=pairs,
        data=(TermData("r", 3, offsets),),
        label="dipole-dipole",
    )
    s30, c30 = 0.5, math.sqrt(3) / 2
    q0 = np.tile([1.0, 0.0, 0.0], (16, 1))
    q0[15] = (s30 * math.cos(_deg(45)), s30 * math.sin(_deg(45)), -c30)
    omega0 = np.zeros((16, 3))
    omega0[0] = (0.0, 0.5, 0.0)
    suffix = "" if (plane, numbering) == ("xy", "row") else f"_{plane}_{numbering}"
    return System.create(
        name=f"dipoles{suffix}",
        n=16,
        parameters={"m": 0.05, "l": 0.02, "nu": 0.1, "mu": 4e-7 * math.pi},
        inertia=m * l**2 / 12 * sp.eye(16),
        potential=sp.Integer(0),
        q0=q0,
        omega0=omega0,
        run=RunSettings(h=2.5e-4, T=10.0, method="vi"),
        origin=f"{_ORIGIN}.dipoles(plane={plane!r}, numbering={numbering!r})",
        terms=[term],
    )
