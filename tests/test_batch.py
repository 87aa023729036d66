"""integrate_batch(): each member bit for bit integrate()'s for that member, failures alone.

The reference is the plain module's integrate() (the module without integrate_batch(), built
with the same flags), called once per member: every member's samples q and omega, its energy,
its status and every field of its statistics must be equal as raw doubles (compared as
uint64, so that -0.0 and 0.0 or two NaN payloads would differ). The batch holds K = 11
members (not a multiple of BATCH_LANES: the last block is padded), every member with its own
parameters and initial state, one with a NaN in q0 (fails before its first sample) and one
with an angular velocity so large that its first step fails (infeasible for the VI, not
finite for Runge-Kutta): their neighbours in the same block must not notice. With a coupled
M (Newton VI), one more member starts upside down at rest under a far stronger gravity:
it speeds up until, some steps in, its Newton iteration does not converge (ERR_NEWTON) while
the others, iterating their own number of times, go on; and one spins 10^4 times faster: the
double pendulum's RK4 then meets a singular A(q) a = b in a stage (ERR_SINGULAR, which the
batch must report as the one-member stage does, not as a non-finite step). With a dense M the
Newton VI runs in loops over the lanes, each lane under its own convergence mask: two broken
variants of the emitted C (every lane stops with lane 0; failed lanes keep iterating; a lane at
newton_maxiter does not fail) must fail the comparison.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from test_chains import banded_chain
from variants import edited

from s2gen.emit import emit
from s2gen.parts.batch import BATCH_LANES, BATCH_METHODS
from s2gen.passes import lower_system
from s2gen.printing.c_batch import batch_work
from s2gen.runtime.batch import integrate_batch
from s2gen.runtime.c import CBackend
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.system import System
from s2gen.systems import builtin, resolve

K, H, NSTEPS, EVERY = 11, 0.01, 60, 6
SPECS = Path(__file__).parent / "specs"
#: The fixed-step batched methods (the adaptive ones: test_batch_adaptive, and here on
#: four_pendula, where FAST_MEMBER's steps shrink until the step budget stops it).
FIXED = tuple(m for m in BATCH_METHODS if m not in ("rk45", "dop853"))
NAN_MEMBER, FAST_MEMBER, LATE_MEMBER, SPIN_MEMBER = 3, 9, 6, 1
#: How much stronger LATE_MEMBER's gravity is: enough that its Newton fails some steps in
#: (step 9 of the double pendulum, 5 of the rope, 10 of the pendulum chain, 17 of chain4).
LATE_GRAVITY = {"double_pendulum": 1e3}


def system(name: str) -> System:
    """A built-in (with its options: ``rope:n=10``), a spec of tests/specs (``springs4``: a
    general potential alone; ``chain4``: four coupled links) or ``banded``: nine bodies whose
    M couples neighbours (test_chains' banded solver)."""
    if name == "banded":
        return banded_chain()
    specs = ("springs4", "chain4", "coupled_field")
    return resolve(str(SPECS / f"{name}.toml")) if name in specs else resolve(name)


def members(
    name: str, late: bool = False, own: str | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K perturbed copies of the spec's state and parameters, two of them made to fail (three
    when `late`: LATE_MEMBER upside down at rest, its gravity g LATE_GRAVITY times larger, and
    SPIN_MEMBER 10^4 times faster). With `own`, the first BATCH_LANES members share member
    0's parameters except parameter `own`, which each keeps its own."""
    s = system(name)
    rng = np.random.default_rng(7)
    q0 = s.q0[None] + 1e-2 * rng.standard_normal((K, s.n, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = s.omega0[None] + 0.1 * rng.standard_normal((K, s.n, 3))
    w0 -= np.sum(w0 * q0, axis=2, keepdims=True) * q0
    p = np.array(s.parameter_values)[None] * (1 + 0.2 * rng.random((K, len(s.parameter_values))))
    if own is not None:
        keep = p[:BATCH_LANES, s.parameter_names.index(own)].copy()
        p[:BATCH_LANES] = p[0]
        p[:BATCH_LANES, s.parameter_names.index(own)] = keep
    q0[NAN_MEMBER, 0, 1] = np.nan
    w0[FAST_MEMBER] *= 1e170
    if late:
        q0[LATE_MEMBER] = -s.q0 + 1e-3
        q0[LATE_MEMBER] /= np.linalg.norm(q0[LATE_MEMBER], axis=1, keepdims=True)
        w0[LATE_MEMBER] = 0.0
        p[LATE_MEMBER, s.parameter_names.index("g")] *= LATE_GRAVITY.get(name, 30.0)
        w0[SPIN_MEMBER] *= 1e4
    return q0, w0, p


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.uint64)


def check(
    name: str,
    methods: tuple[str, ...],
    opt: str | None,
    late: bool = False,
    files: dict[str, str] | None = None,
    options: Options | None = None,
    own: str | None = None,
    renamed: str | None = None,
) -> None:
    """Every member of the batch against integrate() of that member alone (`files`: the
    batched module's C, by default the emitted one), both with `options` (default Options());
    `own`: see `members`; `renamed`: the system under that module name."""
    s = system(name)
    if renamed is not None:
        s = dataclasses.replace(s, name=renamed)
    one, batched = CBackend(s, opt=opt), CBackend(s.with_batch(), files, opt=opt)
    assert not one.library.batch and batched.library.batch
    q0, w0, p = members(name, late, own)
    assert K % BATCH_LANES != 0
    for m in methods:
        b = integrate_batch(batched, m, H, NSTEPS, q0, w0, p, options or Options(), EVERY)
        assert b.energy is not None
        for k in range(K):
            status, q, w, e, stats = one.integrate(
                m, H, NSTEPS, q0[k], w0[k], p[k], options or Options(), EVERY
            )
            assert e is not None
            done = int(stats["fail_step"]) if status else q.shape[0]
            where = f"{name} {m} member {k}"
            assert int(b.status[k]) == status, where
            assert {
                f: int(v[k]) if f != "fail_time" else float(v[k]) for f, v in b.stats.items()
            } == stats, where
            assert np.array_equal(bits(b.q[k, :done]), bits(q[:done])), where
            assert np.array_equal(bits(b.omega[k, :done]), bits(w[:done])), where
            assert np.array_equal(bits(b.energy[k, :done]), bits(e[:done])), where
            assert np.isnan(b.q[k, done:]).all(), where  # nothing written past a failure
        failing = (NAN_MEMBER, FAST_MEMBER) + ((LATE_MEMBER, SPIN_MEMBER) if late else ())
        ok = [k for k in range(K) if k not in failing]
        assert (b.status[ok] == 0).all() and b.status[NAN_MEMBER] == 3, m
        assert b.status[FAST_MEMBER] != 0 and b.stats["fail_step"][FAST_MEMBER] == 1, m
        if late and not m.startswith("rk"):  # Newton fails some steps in, the others go on
            assert b.status[LATE_MEMBER] == 2 and b.stats["steps"][LATE_MEMBER] > 0, m
        if late and name == "double_pendulum" and m == "rk4":
            assert b.status[SPIN_MEMBER] == 6, m  # a singular solve in a stage


def test_four_pendula_every_method() -> None:
    """Explicit VI, its compositions, the fixed-step Runge-Kutta methods and RK45 and DOP853
    (listed and body terms with member tables), portable flags."""
    check("four_pendula", BATCH_METHODS, "portable")


def test_a_module_named_like_a_size_macro_reads_its_own_sizes() -> None:
    """A module called four_batch defines FOUR_BATCH_WORK_SIZE, its one-member WORK_SIZE: the
    runtime reads BATCH_WORK_SIZE by its whole name (taken by how a macro ends, the batch got
    the one-member workspace and wrote past it)."""
    s = dataclasses.replace(system("four_pendula"), name="four_batch").with_batch()
    module = lower_system(s)
    lib = CBackend(s, opt="portable").library
    assert (lib.batch_work, lib.work.size) == (batch_work(module)["size"], module.work_size)
    check("four_pendula", ("vi", "rk4"), "portable", renamed="four_batch")


def test_dipoles_vi() -> None:
    """The VI and RK4 of a system whose gradient runs through its quadratic form (K), every
    member with its own parameters: each lane's K differs (dV/dq lane by lane)."""
    check("dipoles", ("vi", "rk4"), "portable")


@pytest.mark.parametrize("opt", ["portable", "native"])
def test_dipoles_shared_k(opt: str) -> None:
    """The dipoles' VI and RK4 with Kx + b in loops over the lanes: the first block's members
    share the parameters K depends on, each with its own mass m (its own M; a NaN member
    among them), the second block's members differ in every parameter (each lane its own K,
    lane by lane); -O2 and -O3 -march=native."""
    check("dipoles", ("vi", "rk4"), opt, own="m")


def test_linear_part_shared_k() -> None:
    """Quadratic terms with a linear part: Kx + b in loops over the lanes (the first block's
    members share k and f, each with its own mass m), b added as quadratic_soa adds it."""
    check("coupled_field", ("vi", "rk4"), "portable", own="m")


@pytest.mark.slow
@pytest.mark.parametrize("opt", ["portable", "native"])
def test_dipoles_shared_k_every_method(opt: str) -> None:
    """Every batched method of the dipoles with the first block's lanes sharing K (as in
    test_dipoles_shared_k), -O2 and -O3 -march=native."""
    check("dipoles", FIXED, opt, own="m")


def _k_reassociated(c: str, upper: str) -> str:
    """The lanes' four-column pass of Kx summed left to right instead of in pairs."""
    return edited(
        c,
        "ai[l] += (a0 * x0[l] + a1 * x1[l]) + (a2 * x2[l] + a3 * x3[l]);",
        "ai[l] += ((a0 * x0[l] + a1 * x1[l]) + a2 * x2[l]) + a3 * x3[l];",
    )


def _k_always_shared(c: str, upper: str) -> str:
    """Every block's lanes take lane 0's K, whether or not their own K equals it."""
    return edited(c, "b->shared_k = 0;", "")


@pytest.mark.parametrize("broken", [_k_reassociated, _k_always_shared])
def test_broken_shared_k_is_caught(broken: Callable[[str, str], str]) -> None:
    """The lanes' Kx + b must be quadratic_soa's sum in its order, and only lanes whose K is
    lane 0's may share it: either broken variant fails the comparison on the dipoles' VI."""
    s = system("dipoles")
    files = dict(emit(s.with_batch(), "c"))
    source = f"{s.name}.c"
    files[source] = broken(files[source], s.name.upper())
    with pytest.raises(AssertionError, match="dipoles vi member"):
        check("dipoles", ("vi",), "portable", files=files, own="m")


@pytest.mark.slow
@pytest.mark.parametrize("opt", ["portable", "native"])
@pytest.mark.parametrize("name", ["four_pendula", "three_bodies", "dipoles", "springs4"])
def test_every_method_both_flag_sets(name: str, opt: str) -> None:
    """Every batched method, four systems (listed and body terms with member tables: dV/dq in
    loops over the lanes; pair rows and quadratic terms: dV/dq lane by lane; a general
    potential: its kernel in a loop over the lanes), -O2 and -O3 -march=native."""
    check(name, FIXED, opt)


@pytest.mark.parametrize("opt", ["portable", "native"])
def test_double_pendulum_newton(opt: str) -> None:
    """A dense M: the Newton VI and a composition in loops over the lanes (each lane its own
    iterations under its own mask, a member whose Newton fails mid-run stops alone), RK4 with
    A(q) a = b solved in loops over the lanes; -O2 and -O3 -march=native."""
    check("double_pendulum", ("vi", "vi4", "rk4"), opt, late=True)


@pytest.mark.parametrize("opt", ["portable", "native"])
def test_rope_newton(opt: str) -> None:
    """A 10-link rope, M of max-index structure (its VI's block solves in loops over the
    lanes, tests/test_batch_chain.py; its field lane by lane): the Newton VI and RK4, -O2 and
    -O3 -march=native."""
    check("rope:n=10", ("vi", "rk4"), opt, late=True)


def test_newton_limit_fails_alone() -> None:
    """With newton_maxiter = 4 the double pendulum's speeding-up member needs more iterations
    some steps in and fails at the limit (ERR_NEWTON) in its lane alone; the others, which
    need at most 3, go on bit for bit."""
    limit = Options(newton_maxiter=4)
    check("double_pendulum", ("vi", "vi4"), "portable", late=True, options=limit)
    s = system("double_pendulum")
    q0, w0, p = members("double_pendulum", late=True)
    b = integrate_batch(CBackend(s.with_batch(), opt="portable"), "vi", H, NSTEPS, q0, w0, p, limit)
    assert b.stats["newton_max"][LATE_MEMBER] == 4 and b.stats["steps"][LATE_MEMBER] > 0


def _lane0_decides(c: str, upper: str) -> str:
    """Every active lane stops when lane 0's convergence test holds."""
    return edited(c, "act[l] = !converged;", "act[l] = l == 0 ? !converged : act[0];")


def _failures_unmasked(c: str, upper: str) -> str:
    """A lane whose Newton fails keeps iterating (its mask follows convergence alone)."""
    cleared = re.subn(r"\n *act\[l\] = 0;", "", c)
    assert cleared[1] == 2 and cleared[0].count("act[l] = !converged;") == 1
    return cleared[0].replace(
        "act[l] = !converged;", f"act[l] = !converged || st[l] != {upper}_OK;"
    )


def _limit_unflagged(c: str, upper: str) -> str:
    """A lane still iterating at newton_maxiter keeps its status OK (its step is taken)."""
    return edited(c, f"st[l] = {upper}_ERR_NEWTON; /* not converged within newton_maxiter */", "")


@pytest.mark.parametrize(
    ("broken", "options"),
    [
        (_lane0_decides, Options()),
        (_failures_unmasked, Options()),
        (_limit_unflagged, Options(newton_maxiter=4)),
    ],
)
def test_broken_lane_masks_are_caught(broken: Callable[[str, str], str], options: Options) -> None:
    """The Newton VI's per-lane masks matter: a batch whose lanes all take lane 0's
    iterations, whose failed lanes go on iterating, or whose lanes at the iteration limit do
    not fail, is not integrate() member by member (the comparison above fails on the double
    pendulum's VI)."""
    s = system("double_pendulum")
    files = dict(emit(s.with_batch(), "c"))
    source = f"{s.name}.c"
    files[source] = broken(files[source], s.name.upper())
    with pytest.raises(AssertionError, match="double_pendulum vi member"):
        check("double_pendulum", ("vi",), "portable", late=True, files=files, options=options)


@pytest.mark.slow
@pytest.mark.parametrize("opt", ["portable", "native"])
@pytest.mark.parametrize(
    "name",
    ["double_pendulum", "rope:n=10", "pendulum_chain", "chain4", "rope:n=10,solver=dense"],
)
def test_coupled_every_method_both_flag_sets(name: str, opt: str) -> None:
    """Every batched method with a coupled M (dense, its Newton VI in loops over the lanes:
    the double pendulum, the pendulum chain, a four-link spec and the 10-link rope solved
    densely; max-index, its VI's block solves in the lanes: the rope), -O2 and -O3 -march=native."""
    check(name, FIXED, opt, late=True)


@pytest.mark.slow
@pytest.mark.parametrize("opt", ["portable", "native"])
def test_banded_every_method_both_flag_sets(opt: str) -> None:
    """Every batched method with a banded M (its structured solver, lane by lane)."""
    check("banded", FIXED, opt)


def test_model_integrate_batch() -> None:
    """Model.integrate_batch: parameters by name, one K for all, the spec's state by default,
    member-first arrays; a member's run equals Model.integrate's."""
    model = Model(builtin("four_pendula"))
    b = model.integrate_batch("vi", h=0.01, T=0.2, params={"g": [9.0, 9.5, 10.0]}, every=4)
    assert b.q.shape == (3, 6, 4, 3) and b.omega.shape == b.q.shape
    assert b.energy is not None and b.energy.shape == (3, 6)
    tr = model.integrate("vi", h=0.01, T=0.2, params={"g": 9.5}, every=4)
    assert np.array_equal(bits(b.q[1]), bits(tr.q)) and np.array_equal(b.t, tr.t)
    assert np.array_equal(bits(b.energy[1]), bits(tr.energy))


def test_refusals() -> None:
    """What is not covered is refused in one line: a driven system's inputs as state feedback
    (a driven system's batch: test_batch_driven), a method that is not batched, the reference
    backend (the NumPy backend's batch: test_batch_numpy), members that disagree on K."""
    with pytest.raises(ValueError, match="not state feedback"):
        Model(builtin("forced_double_pendulum")).integrate_batch(
            "vi", h=0.01, T=0.1, params={"c": [0.1, 0.2]}, inputs=lambda t, q, w: []
        )
    model = Model(builtin("four_pendula"))
    with pytest.raises(ValueError, match="'vi-adaptive' is not batched"):
        model.integrate_batch("vi-adaptive", h=0.01, T=0.1, params={"g": [1.0, 2.0]})
    with pytest.raises(ValueError, match="one K for all"):
        model.integrate_batch("vi", h=0.01, T=0.1, params={"g": [1.0, 2.0], "m": [1.0]})
    with pytest.raises(ValueError, match="the C and NumPy backends only"):
        Model(builtin("four_pendula"), "reference").integrate_batch("vi", h=0.01, T=0.1)
