"""The two benchmark systems as TOML specs, and the formulas their numbers come from.

Input: nothing (from ``benchmarks/``, ``python -m unseen_systems.specs [FOLDER]`` rewrites the
files).
Output: ``yukawa.toml`` and ``chain.toml`` (by default beside this module, where the benchmark
reads them), written from `yukawa_spec` and `chain_spec`. The numbers (masses, charges, lengths,
spring constants, initial states) follow from short closed formulas so that the files can be
rebuilt and checked; the benchmark and its hand-written C read only the TOML.

- yukawa: n = 100 charges on the unit sphere with their own masses and charges c_i, a screened
  Coulomb pair potential A c_i c_j exp(-kappa r_ij) / r_ij over every pair (r_ij = |q_i - q_j|)
  and a uniform field along e3 acting on each charge. Diagonal inertia: the explicit VI.
- chain: a chain of n = 10 spherical pendula (point masses m_i on massless links of length l_i)
  under gravity along e3, with torsional springs k_i (1 - q_i . q_i+1) between neighbouring
  links. M_ij = l_i l_j sum_{k >= max(i, j)} m_k is full: the implicit VI (Newton).

Example:
    >>> text = yukawa_spec()
    >>> text.splitlines()[0].startswith("#"), 'name = "yukawa"' in text
    (True, True)
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

__all__ = ["HERE", "MIXTURE_SPECIES", "chain_spec", "mixture_spec", "write_specs", "yukawa_spec"]

HERE = Path(__file__).resolve().parent
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # fractional parts of k * _GOLDEN spread evenly


def _frac(x: float) -> float:
    return x - math.floor(x)


def _num(x: float) -> str:
    return repr(float(x))


def _vectors(rows: list[list[float]], indent: str) -> str:
    inner = (",\n" + indent).join("[" + ", ".join(_num(x) for x in row) + "]" for row in rows)
    return "[" + inner + "]"


def _numbers(values: list[float], per_line: int = 6, indent: str = "     ") -> str:
    chunks = [
        ", ".join(_num(v) for v in values[k : k + per_line])
        for k in range(0, len(values), per_line)
    ]
    return "[" + (",\n" + indent).join(chunks) + "]"


def _tangent(q: tuple[float, float, float], angle: float, speed: float) -> list[float]:
    """speed (cos(angle) u + sin(angle) v), with (u, v) the east/north basis at q."""
    x, y, z = q
    rho = math.hypot(x, y)
    u = (-y / rho, x / rho, 0.0)
    v = (-z * x / rho, -z * y / rho, rho)
    return [speed * (math.cos(angle) * a + math.sin(angle) * b) for a, b in zip(u, v)]


def yukawa_spec(n: int = 100) -> str:
    """The yukawa system's TOML: charges on a Fibonacci lattice of the sphere.

    Body k (k = 1..n): q_k on the Fibonacci lattice (z = 1 - (2k - 1)/n, azimuth k times the
    golden angle), mass 1 + frac(k g)/2 and charge 1/2 + frac(k sqrt 2) (g the golden ratio's
    fractional part), omega_k of size 0.4 + 0.2 frac(k sqrt 3) in the direction 2.4 k rad
    from east in the tangent plane.
    """
    golden_angle = math.pi * (3.0 - math.sqrt(5.0))
    q, w, mass, charge = [], [], [], []
    for k in range(1, n + 1):
        z = 1.0 - (2 * k - 1) / n
        rho = math.sqrt(1.0 - z * z)
        phi = k * golden_angle
        qk = (rho * math.cos(phi), rho * math.sin(phi), z)
        q.append(list(qk))
        w.append(_tangent(qk, 2.4 * k, 0.4 + 0.2 * _frac(k * math.sqrt(3.0))))
        mass.append(round(1.0 + 0.5 * _frac(k * _GOLDEN), 6))
        charge.append(round(0.5 + _frac(k * math.sqrt(2.0)), 6))
    steps, h = 2000, 0.002
    return f"""\
# Screened Coulomb (Yukawa) charges on the unit sphere: n = {n} bodies, each with its own mass
# m_i and charge c_i, interacting over every pair i < j through
#     V_ij = A c_i c_j exp(-kappa r_ij) / r_ij,   r_ij = |q_i - q_j|,
# in a uniform field E along e3 (V_i = -E c_i e3 . q_i). The inertia is diagonal, so the
# variational integrator is explicit.
#
# The masses m and charges c are per-body data ([data]): the inertia reads m, the field term
# c and the pair term, over pairs = "all", ci and cj (the charges of the pair's two bodies).
#
# Written by unseen_systems.specs: Fibonacci lattice positions; mass
# 1 + frac(k g)/2, charge 1/2 + frac(k sqrt 2) for body k (g = (sqrt 5 - 1)/2); tangent
# angular velocities of size 0.4 + 0.2 frac(k sqrt 3).

name = "yukawa"
bodies = {n}

[parameters]
A = 0.1      # coupling strength
kappa = 3.0  # inverse screening length
E = 0.5      # field strength along e3

[data]
m = {_numbers(mass)}
c = {_numbers(charge)}

[inertia]
diagonal = "m"

[[potential.body]]
V = "-E*c*dot(e3, q)"
bodies = "all"

[[potential.pair]]
V = "A*ci*cj*exp(-kappa*norm(qi - qj))/norm(qi - qj)"
pairs = "all"

[initial]
q = {_vectors(q, "     ")}
omega = {_vectors(w, "         ")}

[run]
h = {h}
T = {steps * h}
method = "vi"
"""


def chain_spec(n: int = 10) -> str:
    """The chain system's TOML: n spherical pendula in series with neighbour springs.

    Link k (k = 1..n): mass 0.5 + 0.1 ((3k) mod 7), length 0.2 + 0.02 ((5k) mod 6), spring
    k_k = 2 + k/2 to link k + 1; q_k tilted 0.2 + 0.03 k rad from e3 at azimuth 0.7 k;
    omega_k of size 1 + 0.1 k in the direction 1.3 k rad from east in the tangent plane.
    """
    m = [f"m{k}" for k in range(1, n + 1)]
    length = [f"l{k}" for k in range(1, n + 1)]

    def below(k: int) -> str:  # the mass carried by link k (1-based): m_k + ... + m_n
        return m[k - 1] if k == n else "(" + " + ".join(m[k - 1 :]) + ")"

    rows = []
    for i in range(1, n + 1):
        entries = [f'"{length[i - 1]}*{length[j - 1]}*{below(max(i, j))}"' for j in range(1, n + 1)]
        rows.append("[" + ", ".join(entries) + "]")
    gravity = " + ".join(f"{below(k)}*{length[k - 1]}*q{k}[2]" for k in range(1, n + 1))
    params = "\n".join(
        [f"m{k} = {_num(0.5 + 0.1 * ((3 * k) % 7))}" for k in range(1, n + 1)]
        + [f"l{k} = {_num(round(0.2 + 0.02 * ((5 * k) % 6), 6))}" for k in range(1, n + 1)]
    )
    q, w = [], []
    for k in range(1, n + 1):
        theta, phi = 0.2 + 0.03 * k, 0.7 * k
        qk = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
        q.append(list(qk))
        w.append(_tangent(qk, 1.3 * k, 1.0 + 0.1 * k))
    springs = [2.0 + 0.5 * k for k in range(1, n)]
    steps, h = 5000, 0.001
    matrix = "[" + ",\n     ".join(rows) + "]"
    return f"""\
# A chain of n = {n} spherical pendula: point masses m_k on massless links of length l_k, link 1
# hanging from a fixed pivot, link k + 1 from the end of link k, under gravity g along e3,
# with torsional springs k_k (1 - q_k . q_k+1) between neighbouring links. q_k is the unit
# vector along link k. The inertia
#     M_ij = l_i l_j (m_max(i,j) + ... + m_n)
# couples every pair of links, so the variational integrator is implicit (Newton on the
# Cayley parameters).
#
# Written by unseen_systems.specs: mass 0.5 + 0.1 ((3k) mod 7), length
# 0.2 + 0.02 ((5k) mod 6), spring 2 + k/2 for link k; q_k tilted 0.2 + 0.03 k rad from e3 at
# azimuth 0.7 k; tangent angular velocities of size 1 + 0.1 k.

name = "chain"
bodies = {n}

[parameters]
g = 9.81
{params}

[inertia]
M = {matrix}

[potential]
V = "-g*({gravity})"

[[potential.pair]]
V = "k*(1 - dot(qi, qj))"
pairs = "chain"
[potential.pair.data]
k = {_numbers(springs)}

[initial]
q = {_vectors(q, "     ")}
omega = {_vectors(w, "         ")}

[run]
h = {h}
T = {steps * h}
method = "vi"
"""


#: The mixture's two species: (mass, sigma, epsilon) of the small (A) and large (B) particles.
MIXTURE_SPECIES = {"A": (1.0, 0.065, 1.0), "B": (1.5, 0.08, 0.8)}


def mixture_spec(n: int = 2000, steps: int = 250) -> str:
    """The mixture system's TOML: two species of Lennard-Jones particles with a cutoff.

    Body k (k = 1..n): q_k on the Fibonacci lattice (as yukawa's), species B when
    frac(k sqrt 2) < 0.4 and A otherwise (mass, sigma, epsilon from `MIXTURE_SPECIES`),
    omega_k of size 0.3 + 0.3 frac(k sqrt 3) in the direction 2.4 k rad from east in the
    tangent plane. The cutoff is 2.5 times the larger sigma. `n` smaller than 2000 keeps the
    particles' spacing by shrinking the sigmas, the cutoff and h with it.
    """
    golden_angle = math.pi * (3.0 - math.sqrt(5.0))
    shrink = math.sqrt(2000.0 / n)  # the mean spacing grows as 1/sqrt(n)
    q, w, mass, sigma, eps = [], [], [], [], []
    for k in range(1, n + 1):
        z = 1.0 - (2 * k - 1) / n
        rho = math.sqrt(1.0 - z * z)
        phi = k * golden_angle
        qk = (rho * math.cos(phi), rho * math.sin(phi), z)
        q.append(list(qk))
        w.append(_tangent(qk, 2.4 * k, (0.3 + 0.3 * _frac(k * math.sqrt(3.0))) * shrink))
        m, s, e = MIXTURE_SPECIES["B" if _frac(k * math.sqrt(2.0)) < 0.4 else "A"]
        mass.append(m)
        sigma.append(round(s * shrink, 6))
        eps.append(e)
    rc = round(2.5 * max(s for _, s, _ in MIXTURE_SPECIES.values()) * shrink, 6)
    h = round(0.0005 * shrink, 8)
    x = "(si + sj)**2/(4*dot(qi - qj, qi - qj))"
    xc = "(si + sj)**2/(4*rc**2)"
    pair = f"4*sqrt(ei*ej)*(({x})**6 - ({x})**3 - ({xc})**6 + ({xc})**3)"
    return f"""\
# A two-species Lennard-Jones mixture on the unit sphere: n = {n} particles, each of species A
# or B with its own mass m_i, size sigma_i (s) and well depth epsilon_i (e), interacting over
# the pairs closer than rc (chord distance r_ij = |q_i - q_j|) through the truncated and
# shifted potential
#     V_ij = 4 e_ij ((s_ij/r_ij)^12 - (s_ij/r_ij)^6) - (the same at r_ij = rc),
# with the Lorentz-Berthelot mixing rule s_ij = (s_i + s_j)/2, e_ij = sqrt(e_i e_j). The
# inertia is diagonal, so the variational integrator is explicit.
#
# The species are per-body data ([data] m, s, e): the inertia reads m and the pair term, over
# pairs = "all" with a cutoff, si, sj, ei and ej.
#
# Written by unseen_systems.specs: Fibonacci lattice positions; species B (m, s, e =
# {MIXTURE_SPECIES["B"]}) for body k when frac(k sqrt 2) < 0.4, else A ({MIXTURE_SPECIES["A"]});
# tangent angular velocities of size 0.3 + 0.3 frac(k sqrt 3).

name = "mixture"
bodies = {n}

[parameters]
rc = {rc}  # the cutoff: 2.5 times the larger sigma

[data]
m = {_numbers(mass, 10)}
s = {_numbers(sigma, 10)}
e = {_numbers(eps, 10)}

[inertia]
diagonal = "m"

[[potential.pair]]
V = "{pair}"
pairs = "all"
cutoff = "rc"

[initial]
q = {_vectors(q, "     ")}
omega = {_vectors(w, "         ")}

[run]
h = {h}
T = {round(steps * h, 10)}
method = "vi"
"""


def write_specs(folder: str | Path = HERE) -> list[Path]:
    """Write yukawa.toml, chain.toml and mixture.toml into `folder`; returns their paths.

    Example:
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     [p.name for p in write_specs(d)]
        ['yukawa.toml', 'chain.toml', 'mixture.toml']
    """
    folder = Path(folder)
    out = []
    specs = (("yukawa", yukawa_spec()), ("chain", chain_spec()), ("mixture", mixture_spec()))
    for name, text in specs:
        path = folder / f"{name}.toml"
        path.write_text(text, encoding="utf-8")
        out.append(path)
    return out


if __name__ == "__main__":
    for written in write_specs(sys.argv[1] if len(sys.argv) > 1 else HERE):
        print(written)
