"""integrate_batch() with a max-index M: the VI's block solves in loops over the lanes.

The rope's and the elastic rod's Newton and velocity systems are solved by block elimination
body by body (c/_coupled_chain.jinja's block_solve, with the band LU as its fallback). In a
batch the elimination runs on all lanes at once, each lane with its own pivot rows and its
own decline flag, and a lane whose elimination declines redoes that solve with the
one-member solver. The reference is integrate() of each member alone (the module without
integrate_batch(), the same flags): every member's samples, energy, status and statistics
must be equal as raw uint64 (test_batch.check). The members differ in parameters and state,
K = 11 is not a multiple of BATCH_LANES, and some fail (a NaN, a first step that cannot be
taken, a Newton that stops converging some steps in) while their neighbours go on.

A system whose first block is singular (or within 1e-9 of it) for some members only, as
tests/test_block_elimination.py builds it but with the offset a parameter, puts declining
lanes beside lanes that do not decline. Broken variants of the emitted C (every lane taking
lane 0's pivot rows; lanes pivoting on different rows taken for lanes pivoting on one; the
rows not exchanged where all lanes pivot on one; a declining lane keeping its block
elimination's result instead of the band's; a declining lane solving with stale blocks
instead of those the kernels wrote into the lanes; the lanes' kernels reading Cayley
parameters not updated) must fail the comparison.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from test_batch import FAST_MEMBER, NAN_MEMBER, K, bits, check, members
from variants import edited

from s2gen.emit import emit
from s2gen.equations.structure import choose_solver
from s2gen.inertia import InertiaKind
from s2gen.parts.batch import BATCH_LANES
from s2gen.runtime.batch import integrate_batch
from s2gen.runtime.c import CBackend
from s2gen.runtime.options import Options
from s2gen.spec import define_system
from s2gen.system import System
from s2gen.systems import resolve

N, H, NSTEPS, EVERY = 6, 1e-3, 80, 8
#: The offset d of each member of the pivoted system: 0 makes its first block singular, 1e-9
#: nearly so (both decline), 0.5 regular; the declining members share blocks with the others.
OFFSETS = (0.0, 0.5, 0.5, 1e-9, 0.5, 0.0, 0.5, 0.5, 0.5, 1e-9, 0.5)


def pivoted() -> System:
    """M = C + diag(d - 1, 1, ..., 1) + diag(d), C_ij = c_max(i,j), c_i = n - i + 1 (as in
    tests/test_block_elimination.py, positive definite for d >= 0): the first block of the
    block elimination is singular exactly when d = 0."""
    q0 = [[np.sin(0.3 * k), 0.0, np.cos(0.3 * k)] for k in range(N)]
    w0 = [[-0.5 * np.cos(0.3 * k), 1.0 + 0.1 * k, 0.5 * np.sin(0.3 * k)] for k in range(N)]
    return define_system(
        name="pivoted",
        bodies=N,
        parameters={"k": 1.5, "d": 0.5},
        diagonal="n - i + 1 + e + d",
        max_index="n - i + 1",
        inertia_data={"e": [-1.0] + [1.0] * (N - 1)},
        pair_terms=[{"V": "k*(1 - dot(qi, qj))", "pairs": "chain"}],
        initial_q=q0,
        initial_omega=w0,
        inertia_solver="structured",
    )


def pivoted_members() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K members of `pivoted`: perturbed states, their own k, and d from OFFSETS."""
    s = pivoted()
    rng = np.random.default_rng(3)
    q0 = s.q0[None] + 1e-2 * rng.standard_normal((K, N, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = s.omega0[None] + 0.1 * rng.standard_normal((K, N, 3))
    w0 -= np.sum(w0 * q0, axis=2, keepdims=True) * q0
    p = np.stack([1.5 * (1 + 0.2 * rng.random(K)), np.array(OFFSETS)], axis=1)
    return q0, w0, p


def compare(
    s: System,
    members: tuple[np.ndarray, np.ndarray, np.ndarray],
    methods: tuple[str, ...],
    opt: str,
    h: float,
    files: dict[str, str] | None = None,
) -> np.ndarray:
    """Every member of `s`'s batch against integrate() of that member alone, with step `h`
    (`files`: the batched module's C, by default the emitted one); returns the statuses."""
    q0, w0, p = members
    one, batched = CBackend(s, opt=opt), CBackend(s.with_batch(), files, opt=opt)
    assert K % BATCH_LANES != 0 and len(q0) == K
    for m in methods:
        b = integrate_batch(batched, m, h, NSTEPS, q0, w0, p, Options(), EVERY)
        assert b.energy is not None
        for k in range(K):
            status, q, w, e, stats = one.integrate(
                m, h, NSTEPS, q0[k], w0[k], p[k], Options(), EVERY
            )
            assert e is not None
            done = int(stats["fail_step"]) if status else q.shape[0]
            where = f"{s.name} {m} member {k}"
            assert int(b.status[k]) == status, where
            assert {
                f: int(v[k]) if f != "fail_time" else float(v[k]) for f, v in b.stats.items()
            } == stats, where
            assert np.array_equal(bits(b.q[k, :done]), bits(q[:done])), where
            assert np.array_equal(bits(b.omega[k, :done]), bits(w[:done])), where
            assert np.array_equal(bits(b.energy[k, :done]), bits(e[:done])), where
    return b.status


def check_pivoted(methods: tuple[str, ...], opt: str, files: dict[str, str] | None = None) -> None:
    """Every member of the pivoted system's batch against integrate() of that member alone,
    none failing."""
    s = pivoted()
    assert choose_solver(s) is InertiaKind.MAX_INDEX
    assert (compare(s, pivoted_members(), methods, opt, H, files) == 0).all()


@pytest.mark.parametrize("opt", ["portable", "native"])
def test_rope_vi_in_lanes(opt: str) -> None:
    """The 10-link rope's VI and a composition of it, members failing alone (late=True: a
    NaN, a step that cannot be taken, a Newton that stops converging some steps in, a member
    spinning 10^4 times faster), -O2 and -O3 -march=native."""
    assert "batch_chain_advance" in emit(resolve("rope:n=10").with_batch(), "c")["rope.c"]
    check("rope:n=10", ("vi", "vi4"), opt, late=True)


def test_elastic_rod_vi_in_lanes() -> None:
    """The elastic rod (max-index M, bending terms), its VI, -O2, members perturbed as
    test_batch's (a NaN member and an infeasible first step among them: they fail alone)."""
    s = resolve("elastic_rod")
    assert choose_solver(s) is InertiaKind.MAX_INDEX
    status = compare(s, members("elastic_rod"), ("vi",), "portable", 1e-3)
    assert status[NAN_MEMBER] == 3 and status[FAST_MEMBER] != 0
    assert (np.delete(status, [NAN_MEMBER, FAST_MEMBER]) == 0).all()


@pytest.mark.parametrize("opt", ["portable", "native"])
def test_declining_lanes_beside_the_others(opt: str) -> None:
    """Members whose block elimination declines (a first block singular or within 1e-9 of
    it) in the same blocks as members whose does not: every member bit for bit its own
    integrate(), the decliners through the band LU."""
    check_pivoted(("vi",), opt)


def _lane0_pivots(c: str, upper: str) -> str:
    """Every lane exchanges the rows lane 0 chose."""
    return edited(c, "const long pv = (long)piv[l];", "const long pv = (long)piv[0];")


def _decline_kept(c: str, upper: str) -> str:
    """A lane whose block elimination declines keeps its (finite) result, not the band's."""
    return edited(c, "ok[l] = good[l] == 1.0 && chk[l] == 0.0;", "ok[l] = chk[l] == 0.0;")


def _one_row_for_split_lanes(c: str, upper: str) -> str:
    """Lanes pivoting on different rows are taken for lanes pivoting on one (lane 0's)."""
    return edited(c, "split |= piv[l] != piv[0];", "split |= 0;")


def _blocks_not_copied(c: str, upper: str) -> str:
    """A lane whose elimination declines redoes its solve on the blocks E its workspace held
    before (the kernels wrote this solve's into the lanes only)."""
    return edited(c, "eb[e] = ce[e * L + l];", "")


def _lane_iterate_stale(c: str, upper: str) -> str:
    """The Newton kernels read each lane's Cayley parameters as they were before the
    iteration's update."""
    return edited(c, "cf[k * L + l] = f[k];", "")


def _whole_exchange_skipped(c: str, upper: str) -> str:
    """Where every lane pivots on one row, the rows are not exchanged."""
    return edited(c, "const long pv = (long)piv[0];", "const long pv = (long)k;")


@pytest.mark.parametrize(
    "broken",
    [
        _lane0_pivots,
        _decline_kept,
        _one_row_for_split_lanes,
        _whole_exchange_skipped,
        _blocks_not_copied,
        _lane_iterate_stale,
    ],
)
def test_broken_lane_solves_are_caught(broken: Callable[[str, str], str]) -> None:
    """Each lane's own pivot rows, each lane's decline (with its blocks, which the kernels
    wrote into the lanes, copied back for the one-member solve) and each lane's updated
    iterate matter: the variants fail the comparison on the pivoted system."""
    s = pivoted()
    files = dict(emit(s.with_batch(), "c"))
    files["pivoted.c"] = broken(files["pivoted.c"], "PIVOTED")
    with pytest.raises(AssertionError, match="pivoted vi member"):
        check_pivoted(("vi",), "portable", files)
