"""integrate_batch() with RATTLE: each member bit for bit integrate()'s for that member.

The reference is the plain module's integrate() (the module without integrate_batch(), built
with the same flags), called once per member, as in test_batch.py (whose `check` this file
uses): every member's samples q and omega, its energy, its status and every field of its
statistics must be equal as raw doubles. The batch holds K = 11 members (not a multiple of
BATCH_LANES), each with its own parameters and initial state inside the first block of 8;
one has a NaN in q0 (fails before its first sample), one an angular velocity so large that
its first RATTLE step has no real solution or none that is finite; with a coupled M one more
starts upside down at rest under a far stronger gravity and its Newton iteration fails some
steps in (ERR_NEWTON), and one spins 10^4 times faster, while the others go on.

Five systems: four pendula (diagonal M, RATTLE in loops over the lanes with dV/dq in lanes),
three bodies (diagonal M, dV/dq of pair rows lane by lane through gradient_cx), the dipoles
(diagonal M, Kx + b in lanes where a block's lanes share K, else lane by lane), the double
pendulum and the six-body pendulum chain (dense M: the step in loops over the lanes, Newton
on the multipliers under each lane's own mask, its small solves by the one-member solvers
on each lane's copy) and a ten-link rope (max-index M, the one-member step lane by lane).
Broken variants of the emitted C (a failing lane's gradient evaluations not counted; the
lanes' velocities v = qdot recomputed from omega at every step instead of carried; the
lanes' Newton never warm-started, in lanes or lane by lane; converged lanes updated while
others iterate) must fail the comparison.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from test_batch import LATE_MEMBER, NSTEPS, H, check, members, system
from variants import edited

from s2gen.emit import emit
from s2gen.parts.batch import BATCH_METHODS
from s2gen.runtime.batch import integrate_batch
from s2gen.runtime.c import CBackend
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options

RATTLE = ("rattle", "rattle4", "rattle6", "rattle8")


def test_rattle_methods_are_batched() -> None:
    """Every RATTLE method is among integrate_batch()'s."""
    assert set(RATTLE) <= set(BATCH_METHODS)


@pytest.mark.parametrize(
    ("name", "late"),
    [
        ("four_pendula", False),
        ("three_bodies", False),
        ("double_pendulum", True),
        ("pendulum_chain", True),
    ],
)
def test_every_rattle_method(name: str, late: bool) -> None:
    """rattle, rattle4, rattle6 and rattle8 on a diagonal M in lanes (dV/dq in lanes; dV/dq
    lane by lane) and on a dense M in lanes (two bodies; six, all pairs coupled: a member
    whose Newton fails mid-run stops alone), -O2."""
    check(name, RATTLE, "portable", late=late)


def test_rope_rattle() -> None:
    """A six-link rope (max-index M, its own solver, lane by lane): rattle and rattle4, the
    late member's Newton failing alone, -O2."""
    check("rope:n=6", ("rattle", "rattle4"), "portable", late=True)


def test_dipoles_rattle() -> None:
    """The dipoles' dV/dq is Kx + b alone: the first block's lanes share K (each its own mass
    m) and run Kx + b in loops over the lanes, the second block's each have their own K and
    run it lane by lane; RATTLE reads either as gradient_cx leaves it (0.0 + (Kx + b),
    component-major into body-major). -O2."""
    check("dipoles", ("rattle", "rattle4"), "portable", own="m")


@pytest.mark.slow
def test_rope_every_rattle_method() -> None:
    """The six-link rope through rattle6 and rattle8 too."""
    check("rope:n=6", RATTLE, "portable", late=True)


@pytest.mark.parametrize("name", ["four_pendula", "double_pendulum"])
def test_rattle_native(name: str) -> None:
    """-O3 -march=native (FMA contraction where the machine has it, wider vectors): the lanes
    and the one-member step contract alike, so members stay bit-identical."""
    check(name, ("rattle", "rattle4"), "native", late=name == "double_pendulum")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["three_bodies", "rope:n=10", "pendulum_chain", "dipoles"])
def test_rattle_native_more(name: str) -> None:
    """Every RATTLE method under -O3 -march=native on four more systems (pair rows lane by
    lane; the structured rope; six bodies of a dense M; the dipoles' Kx + b in lanes)."""
    check(name, RATTLE, "native", late=name in ("rope:n=10", "pendulum_chain"))


def test_newton_limit_fails_alone() -> None:
    """With newton_maxiter = 3 the double pendulum's speeding-up member needs more RATTLE
    iterations some steps in and fails at the limit in its lane alone (ERR_NEWTON, earlier
    than without the limit), the others, which need at most 2, going on bit for bit."""
    limit = Options(newton_maxiter=3)
    check("double_pendulum", ("rattle",), "portable", late=True, options=limit)
    s = system("double_pendulum")
    q0, w0, p = members("double_pendulum", late=True)
    be = CBackend(s.with_batch(), opt="portable")
    b = integrate_batch(be, "rattle", H, NSTEPS, q0, w0, p, limit)
    free = integrate_batch(be, "rattle", H, NSTEPS, q0, w0, p, Options())
    assert b.status[LATE_MEMBER] == 2 and b.stats["newton_max"][LATE_MEMBER] == 3
    assert 0 < b.stats["steps"][LATE_MEMBER] < free.stats["steps"][LATE_MEMBER]


def test_rattle_conserves_energy_and_constraints() -> None:
    """Independent of integrate(): the batched RATTLE of nine members (each its own g) keeps
    |q_i| = 1 to rounding, and its energy error, bounded over T = 2 as a symplectic method's,
    falls as h^2: each member's largest relative error shrinks 3 to 5 times when h halves."""
    model = Model(system("four_pendula"))
    g = [9.0, 9.4, 9.8, 10.2, 10.6, 11.0, 11.4, 11.8, 12.2]
    drifts = []
    for h in (0.005, 0.0025):
        b = model.integrate_batch("rattle", h=h, T=2.0, params={"g": g}, every=10)
        assert (b.status == 0).all()
        assert np.abs(np.linalg.norm(b.q, axis=-1) - 1.0).max() < 1e-12
        assert b.energy is not None
        drifts.append(np.abs(b.energy - b.energy[:, :1]).max(axis=1) / np.abs(b.energy[:, 0]))
    assert drifts[0].max() < 1e-3
    ratio = drifts[0] / drifts[1]
    assert ((ratio > 3.0) & (ratio < 5.0)).all(), ratio


def _evals_uncounted(c: str, upper: str) -> str:
    """A lane that fails in RATTLE's position update does not count the gradients of the
    substeps it took in the failing step."""
    line = "stats[b->member[l]].gradient_evals += evals;\n"
    at = c.index("isfinite(d) ?")
    start = c.rindex(line, 0, at)
    assert c.count(line) == 2 and at - start < 200
    return c[:start] + "(void)evals;\n" + c[start + len(line) :]


def _velocities_from_omega(c: str, upper: str) -> str:
    """The lanes' velocities v = qdot recomputed from omega x q at every step (integrate()
    carries v from step to step, and q x v x q differs from v in its last bits)."""
    head = "        for (sub = 0; sub < count && "
    assert c.count(head) == 1
    recompute = (
        "        for (i = 0; i < N; ++i) { for (l = 0; l < L; ++l) {\n"
        "            const double x0 = x[(3 * i) * L + l], x1 = x[(3 * i + 1) * L + l], "
        "x2 = x[(3 * i + 2) * L + l];\n"
        "            const double o0 = om[(3 * i) * L + l], o1 = om[(3 * i + 1) * L + l], "
        "o2 = om[(3 * i + 2) * L + l];\n"
        "            v[(3 * i) * L + l] = o1 * x2 - o2 * x1;\n"
        "            v[(3 * i + 1) * L + l] = o2 * x0 - o0 * x2;\n"
        "            v[(3 * i + 2) * L + l] = o0 * x1 - o1 * x0;\n"
        "        } }\n"
    )
    recompute = recompute.replace("N;", "4;").replace("L;", f"{upper}_BATCH_LANES;")
    recompute = recompute.replace(" * L + l", f" * {upper}_BATCH_LANES + l")
    return c.replace(head, "        if (k > 0) {\n" + recompute + "        }\n" + head)


def _cold_start_each(c: str, upper: str) -> str:
    """Every lane's Newton (lane by lane) starts cold at every step (integrate() warm-starts
    it from the same substep's solution one step before)."""
    return edited(
        c,
        "batch_rattle_lane(b, l, sc, h, k > 0, &stats[b->member[l]]);",
        "batch_rattle_lane(b, l, sc, h, 0, &stats[b->member[l]]);",
    )


def _cold_start_lanes(c: str, upper: str) -> str:
    """The lanes' Newton (a dense M, in loops over the lanes) starts cold at every step."""
    return edited(
        c,
        "batch_rattle_sub(b, sc->fractions[sub] * h, k > 0, evals,",
        "batch_rattle_sub(b, sc->fractions[sub] * h, 0, evals,",
    )


def _converged_lanes_iterate(c: str, upper: str) -> str:
    """A lane whose Newton has converged goes on updating its multipliers while other lanes
    iterate (no mask)."""
    return edited(c, "sv[i * L + l] = going[l] ? s1 : sv[i * L + l];", "sv[i * L + l] = s1;")


@pytest.mark.parametrize(
    ("name", "method", "broken"),
    [
        ("four_pendula", "rattle4", _evals_uncounted),
        ("four_pendula", "rattle", _velocities_from_omega),
        ("double_pendulum", "rattle", _cold_start_lanes),
        ("double_pendulum", "rattle", _converged_lanes_iterate),
        ("rope:n=10", "rattle", _cold_start_each),
    ],
)
def test_broken_variants_are_caught(
    name: str, method: str, broken: Callable[[str, str], str]
) -> None:
    """Each broken variant of the batched RATTLE fails the member-by-member comparison."""
    s = system(name)
    files = dict(emit(s.with_batch(), "c"))
    source = f"{s.name}.c"
    files[source] = broken(files[source], s.name.upper())
    with pytest.raises(AssertionError, match=f"{name} {method} member"):
        check(name, (method,), "portable", late=name != "four_pendula", files=files)
