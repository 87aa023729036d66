"""The member table of an ensemble: perturbed initial states and swept values, reproducibly.

Input: a `System`, the number of perturbation replicas, relative perturbation sizes
(``{"q": 1e-13, "omega": 1e-13}``), sweeps (``{"kappa": "100:1000:10"}`` or a list of
values; ``h`` sweeps the step size), a seed and the run's h and T. Output: a `MemberTable`
of `Member` records; `initial_state` gives a member's (q0, omega0).

Layout: members are numbered sweep point by sweep point (the cartesian product of the sweeps,
the first sweep varying slowest) and, within a point, replica by replica. Replica 0 is the
unperturbed reference; replica r >= 1 is perturbed with the generator
``numpy.random.default_rng([seed, r])``, so the same replica gets the same perturbation at every
sweep point and on every machine.

Perturbation of replica r (both draws are always made, in this order, so perturbing omega
gives the same omega offsets whether or not q is perturbed too):

1. q: for each body a Gaussian 3-vector, projected onto the tangent plane of q_i and
   normalised to a unit vector u_i; q_i' = (q_i + eps_q u_i) / |q_i + eps_q u_i|;
2. omega: likewise a unit tangent vector v_i at q_i';
   omega_i' = omega_i + eps_omega * s * v_i with s = max_i |omega_i| (1 when every omega_i is
   zero), then omega_i' is projected onto the tangent plane of q_i' (as the equations need).

Example:
    >>> from s2gen.systems import builtin
    >>> s = builtin("double_pendulum")
    >>> t = member_table(s, replicas=3, perturb={"omega": 1e-13}, sweep={"g": "1:2:2"},
    ...                  h=0.01, T=0.5)
    >>> [(m.index, m.point, m.replica, m.params) for m in t.members][:4]
    [(0, 0, 0, (('g', 1.0),)), (1, 0, 1, (('g', 1.0),)), (2, 0, 2, (('g', 1.0),)), (3, 1, 0, (('g', 2.0),))]
    >>> q0, w0 = initial_state(s, t, t.members[1])
    >>> bool(abs((w0 - s.omega0).max()) < 1e-12 and (w0 != s.omega0).any())
    True
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from s2gen.system import System

__all__ = [
    "MAX_MEMBERS",
    "MAX_PERTURBATION",
    "PERTURBABLE",
    "STEP",
    "EnsembleError",
    "Member",
    "MemberTable",
    "Sweep",
    "initial_state",
    "initial_states",
    "member_table",
    "parse_assignment",
    "sweep_values",
]

#: What a perturbation may act on: the positions q (then omega is re-projected) and omega.
PERTURBABLE = ("q", "omega")
#: The sweep name of the step size (every other sweep name is a parameter of the system).
STEP = "h"
#: Most members of one ensemble (replicas times sweep points; also the most values of one
#: sweep): the member table and the store's coordinates are held in memory, about 0.3 kB a
#: member. Checked before any member is made.
MAX_MEMBERS = 10**6
#: Largest relative perturbation: a perturbation of q moves a body by at most its unit
#: length, one of omega adds at most the largest |omega_i| (larger ones are not perturbations
#: and overflow the energy of the perturbed members).
MAX_PERTURBATION = 1.0

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_RANGE = re.compile(rf"^({_NUMBER}):({_NUMBER}):(\d+)$")
_LIST = re.compile(rf"^{_NUMBER}(?:,{_NUMBER})*$")


class EnsembleError(ValueError):
    """Bad ensemble input (unknown parameter, bad range, unreachable scheduler ...): one line."""


@dataclass(frozen=True)
class Sweep:
    """One swept quantity: a parameter of the system, or `STEP` ("h"), and its values."""

    name: str
    values: tuple[float, ...]


@dataclass(frozen=True)
class Member:
    """One member: its index, sweep point and replica (0 = unperturbed), the swept parameter
    values and its step size."""

    index: int
    point: int
    replica: int
    params: tuple[tuple[str, float], ...]
    h: float

    @property
    def perturbed(self) -> bool:
        """Whether this member's initial state is perturbed (replica >= 1)."""
        return self.replica > 0


@dataclass(frozen=True)
class MemberTable:
    """Every member of an ensemble, with what made them: perturbation sizes, sweeps, seed."""

    members: tuple[Member, ...]
    replicas: int
    perturb: tuple[tuple[str, float], ...]
    sweeps: tuple[Sweep, ...]
    seed: int
    h: float
    T: float

    def __len__(self) -> int:
        return len(self.members)

    @property
    def points(self) -> int:
        """Number of sweep points (1 without sweeps)."""
        return len(self.members) // self.replicas

    def size(self, what: str) -> float:
        """The relative perturbation size of "q" or "omega" (0 when not perturbed)."""
        return dict(self.perturb).get(what, 0.0)

    def steps(self, member: Member) -> int:
        """Integration steps of a member (T / its h)."""
        return round(self.T / member.h)


def parse_assignment(text: str, what: str) -> tuple[str, str]:
    """Split ``NAME=VALUE`` (a --sweep or --perturb argument) into (NAME, VALUE).

    Example:
        >>> parse_assignment("kappa=100:1000:10", "--sweep")
        ('kappa', '100:1000:10')
    """
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise EnsembleError(f"{what} {text!r}: expected NAME=VALUE")
    return name.strip(), value.strip()


def sweep_values(spec: str | Sequence[float], name: str = "sweep") -> tuple[float, ...]:
    """Values of a sweep: ``START:STOP:COUNT`` (COUNT values from START to STOP, both
    included, evenly spaced), ``V1,V2,...``, or a sequence of numbers.

    Example:
        >>> sweep_values("100:1000:4")
        (100.0, 400.0, 700.0, 1000.0)
        >>> sweep_values("1e-3,2e-3")
        (0.001, 0.002)
    """
    if isinstance(spec, str):
        text = spec.replace(" ", "")
        m = _RANGE.match(text)
        if m:
            count = int(m.group(3))
            if count < 1:
                raise EnsembleError(f"sweep {name}={spec}: COUNT must be at least 1")
            if count > MAX_MEMBERS:
                raise EnsembleError(
                    f"sweep {name}={spec}: {count} values is more than the limit of {MAX_MEMBERS}"
                )
            vals = np.linspace(float(m.group(1)), float(m.group(2)), count)
            return tuple(float(v) for v in vals)
        if not _LIST.match(text):
            raise EnsembleError(
                f"sweep {name}={spec}: expected START:STOP:COUNT (e.g. 100:1000:10) "
                "or a list V1,V2,..."
            )
        return tuple(float(v) for v in text.split(","))
    if len(spec) > MAX_MEMBERS:
        raise EnsembleError(
            f"sweep {name}: {len(spec)} values is more than the limit of {MAX_MEMBERS}"
        )
    values = tuple(float(v) for v in spec)
    if not values:
        raise EnsembleError(f"sweep {name}: no values")
    return values


def _sweeps(system: System, sweep: Mapping[str, str | Sequence[float]] | None) -> tuple[Sweep, ...]:
    out = []
    for name, spec in (sweep or {}).items():
        if name != STEP and name not in system.parameter_names:
            known = ", ".join(system.parameter_names) or "none"
            raise EnsembleError(
                f"unknown sweep parameter {name!r} of {system.name} "
                f"(parameters: {known}; or {STEP}, the step size)"
            )
        values = sweep_values(spec, name)
        if not all(math.isfinite(v) for v in values):
            raise EnsembleError(f"sweep {name}: values must be finite")
        if name == STEP and min(values) <= 0:
            raise EnsembleError(f"sweep {STEP}: step sizes must be positive")
        out.append(Sweep(name, values))
    return tuple(out)


def _check_count(replicas: int, sweeps: tuple[Sweep, ...]) -> None:
    """Refuse more than `MAX_MEMBERS` members, counted before any is made."""
    points = math.prod(len(s.values) for s in sweeps)
    total = replicas * points
    if total > MAX_MEMBERS:
        grid = f"{replicas} members x {points} sweep points = " if sweeps else ""
        raise EnsembleError(
            f"{grid}{total} members is more than the limit of {MAX_MEMBERS} members"
        )


def _perturbations(perturb: Mapping[str, float] | None) -> tuple[tuple[str, float], ...]:
    sizes = []
    for name, size in (perturb or {}).items():
        if name not in PERTURBABLE:
            raise EnsembleError(
                f"cannot perturb {name!r}; choose from {', '.join(PERTURBABLE)} (e.g. omega=1e-13)"
            )
        value = float(size)
        if not (math.isfinite(value) and value > 0):
            raise EnsembleError(f"perturbation size of {name} must be positive (got {size})")
        if value > MAX_PERTURBATION:
            raise EnsembleError(
                f"perturbation size of {name} is relative and at most {MAX_PERTURBATION:g} "
                f"(got {size:g}; e.g. {name}=1e-13)"
            )
        sizes.append((name, value))
    return tuple(sorted(sizes, key=lambda kv: PERTURBABLE.index(kv[0])))


def member_table(
    system: System,
    replicas: int | None = None,
    perturb: Mapping[str, float] | None = None,
    sweep: Mapping[str, str | Sequence[float]] | None = None,
    seed: int = 0,
    h: float | None = None,
    T: float | None = None,
) -> MemberTable:
    """The members of an ensemble: every sweep point times `replicas` initial states.

    `replicas` counts the reference (replica 0) and defaults to 16 with perturbations, 1
    without. Raises `EnsembleError` (a one-line ValueError) on bad input.

    Example:
        >>> from s2gen.systems import builtin
        >>> len(member_table(builtin("double_pendulum"), sweep={"h": [0.01, 0.02]}, T=1.0))
        2
    """
    sizes = _perturbations(perturb)
    sweeps = _sweeps(system, sweep)
    n = replicas if replicas is not None else (16 if sizes else 1)
    if n < 1:
        raise EnsembleError(f"members must be at least 1 (got {n})")
    _check_count(n, sweeps)
    if n > 1 and not sizes:
        raise EnsembleError(
            f"{n} members without a perturbation would be identical; give one (e.g. omega=1e-13)"
        )
    h = h if h is not None else system.run.h
    T = T if T is not None else system.run.T
    if h is None or T is None:
        raise EnsembleError(f"{system.origin}: no step size h or final time T given (spec [run])")
    if not (h > 0 and T > 0):
        raise EnsembleError(f"h and T must be positive (got h={h}, T={T})")
    names = [s.name for s in sweeps]
    members: list[Member] = []
    for point, combo in enumerate(itertools.product(*(s.values for s in sweeps))):
        values = dict(zip(names, combo))
        step = values.pop(STEP, h)
        nsteps = round(T / step)
        if nsteps < 1 or abs(nsteps * step - T) > 1e-9 * T:
            raise EnsembleError(f"T={T:g} is not a whole number of steps h={step:g}")
        params = tuple(values.items())
        for r in range(n):
            members.append(Member(len(members), point, r, params, float(step)))
    return MemberTable(tuple(members), n, sizes, sweeps, int(seed), float(h), float(T))


def _unit_tangent(g: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Each g_i (standard normal draws, shape (..., n, 3)) projected on the tangent plane of
    q_i and normalised: one random unit tangent vector per body."""
    g = g - np.einsum("...ij,...ij->...i", g, q)[..., None] * q
    return g / np.linalg.norm(g, axis=-1)[..., None]


def initial_state(
    system: System, table: MemberTable, member: Member
) -> tuple[np.ndarray, np.ndarray]:
    """(q0, omega0) of a member: the system's initial state, perturbed for replica >= 1
    (`initial_states` for one member).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> t = member_table(s, replicas=2, perturb={"q": 1e-13})
        >>> q0, w0 = initial_state(s, t, t.members[1])
        >>> float(abs(np.linalg.norm(q0, axis=1) - 1).max()) < 1e-15
        True
        >>> float(abs(np.einsum("ij,ij->i", q0, w0)).max()) < 1e-15
        True
    """
    q, w = initial_states(system, table, (member,))
    return q[0], w[0]


def initial_states(
    system: System, table: MemberTable, members: Sequence[Member]
) -> tuple[np.ndarray, np.ndarray]:
    """The initial states of `members` (arrays of shape (K, n, 3)): the system's, perturbed
    for replica >= 1 along random unit tangent directions drawn from the generator seeded by
    (table seed, replica), so that a member's state does not depend on which others are made
    with it (the same arithmetic, row by row).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> t = member_table(s, replicas=3, perturb={"omega": 1e-9})
        >>> q, w = initial_states(s, t, t.members)
        >>> q.shape, bool(np.array_equal(w[2], initial_state(s, t, t.members[2])[1]))
        ((3, 2, 3), True)
    """
    if system.q0 is None or system.omega0 is None:
        raise EnsembleError(f"{system.origin}: no initial state ([initial] q and omega)")
    q0 = np.array(system.q0, dtype=float).reshape(-1, 3)
    w0 = np.array(system.omega0, dtype=float).reshape(-1, 3)
    count = len(members)
    q = np.broadcast_to(q0, (count, *q0.shape)).copy()
    w = np.broadcast_to(w0, (count, *w0.shape)).copy()
    moved = [j for j, m in enumerate(members) if m.perturbed]
    if not moved:
        return q, w
    # each member's two draws (n x 3 for q, then n x 3 for omega) from its own generator
    g = np.stack(
        [
            np.random.default_rng([table.seed, members[j].replica]).standard_normal((2, *q0.shape))
            for j in moved
        ]
    )
    qm, wm = q[moved], w[moved]
    u = _unit_tangent(g[:, 0], qm)
    eps_q, eps_w = table.size("q"), table.size("omega")
    if eps_q:
        qm = qm + eps_q * u
        qm /= np.linalg.norm(qm, axis=-1)[..., None]
    v = _unit_tangent(g[:, 1], qm)
    scale = float(np.linalg.norm(w0, axis=1).max()) or 1.0
    wm = wm + eps_w * scale * v
    wm -= np.einsum("...ij,...ij->...i", wm, qm)[..., None] * qm
    q[moved], w[moved] = qm, wm
    return q, w
