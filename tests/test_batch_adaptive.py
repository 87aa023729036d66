"""integrate_batch() with the adaptive methods: each member bit for bit integrate()'s.

rk45 and dop853 run the lanes of a block in masked lockstep, each lane with its own step-size
sequence (`s2gen.parts.batch`). The reference is the plain module's integrate() (built with the
same flags) called once per member: every member's samples, energy, status and every field of
its statistics must be equal as raw doubles (uint64). The batch holds K = 11 members (the last
block padded), each with its own parameters and initial state, one of them spinning 30 times
faster than the others (its steps and rejections differ from its neighbours' in the same
block), one with a NaN in q0 (fails before its first sample) and one that fails mid-run: on
three_bodies two bodies meet head on (the cotangent potential's singularity: a stage is not
finite, ERR_NONFINITE, its samples before the collision kept), on the coupled systems a NaN
parameter makes its first field (or trial step) fail. Their neighbours must not notice.
Broken variants of the emitted C (every lane stepping with lane 0's h, a rejected step
accepted, the continuous extension's stages counted on lanes that do not need them) must fail
the comparison.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_batch import K, bits, system
from variants import edited

from s2gen.emit import emit
from s2gen.methods import Status
from s2gen.parts.batch import BATCH_LANES
from s2gen.runtime.batch import integrate_batch
from s2gen.runtime.c import CBackend
from s2gen.runtime.options import Options

ADAPTIVE = ("rk45", "dop853")
H, NSTEPS, EVERY = 0.01, 60, 6
NAN_MEMBER, FAST_MEMBER, BAD_MEMBER = 3, 2, 5


def members(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K perturbed copies of the spec's state and parameters; FAST_MEMBER spins 30 times
    faster, NAN_MEMBER has a NaN in q0, BAD_MEMBER fails mid-run (see the module)."""
    s = system(name)
    rng = np.random.default_rng(11)
    q0 = s.q0[None] + 1e-2 * rng.standard_normal((K, s.n, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = s.omega0[None] + 0.1 * rng.standard_normal((K, s.n, 3))
    w0 -= np.sum(w0 * q0, axis=2, keepdims=True) * q0
    p = np.array(s.parameter_values)[None] * (1 + 0.2 * rng.random((K, len(s.parameter_values))))
    w0[FAST_MEMBER] *= 30.0
    q0[NAN_MEMBER, 0, 1] = np.nan
    if name == "three_bodies":  # bodies 0 and 1 head on along the equator, body 2 at the pole
        q0[BAD_MEMBER] = np.eye(3)
        w0[BAD_MEMBER] = [[0.0, 0.0, 3.0], [0.0, 0.0, -3.0], [0.0, 0.0, 0.0]]
    else:
        p[BAD_MEMBER, -1] = np.nan
    return q0, w0, p


def check(
    name: str,
    methods: tuple[str, ...],
    opt: str,
    files: dict[str, str] | None = None,
    options: Options | None = None,
) -> None:
    """Every member of the batch against integrate() of that member alone (`files`: the
    batched module's C, by default the emitted one), both with `options`."""
    s = system(name)
    one, batched = CBackend(s, opt=opt), CBackend(s.with_batch(), files, opt=opt)
    q0, w0, p = members(name)
    opts = options or Options()
    assert K % BATCH_LANES != 0
    for m in methods:
        b = integrate_batch(batched, m, H, NSTEPS, q0, w0, p, opts, EVERY)
        assert b.energy is not None
        for k in range(K):
            status, q, w, e, stats = one.integrate(m, H, NSTEPS, q0[k], w0[k], p[k], opts, EVERY)
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
        ok = [k for k in range(K) if k not in (NAN_MEMBER, BAD_MEMBER)]
        assert (b.status[ok] == 0).all(), m
        assert b.status[NAN_MEMBER] == Status.NONFINITE and b.status[BAD_MEMBER] != 0, m
        # the lanes of the first block took their own step sequences
        steps = b.stats["steps"][:BATCH_LANES]
        assert len(set(steps[ok[:6]].tolist())) > 1, m
        if name == "three_bodies":  # the collision: some samples, then a non-finite stage
            assert b.status[BAD_MEMBER] == Status.NONFINITE, m
            assert b.stats["fail_step"][BAD_MEMBER] > 1, m


@pytest.mark.parametrize("name", ["three_bodies", "double_pendulum", "rope:n=6"])
def test_adaptive_bit_identical(name: str) -> None:
    """rk45 and dop853 on an explicit system (three_bodies: the field in loops over the
    lanes), a dense M (the double pendulum: A(q) a = b solved in the lanes) and a chain of
    max-index structure (the rope: its solver lane by lane), -O2."""
    check(name, ADAPTIVE, "portable")


def test_adaptive_hairer_control() -> None:
    """Hairer's error control and initial step and a step-size limit hmax, every sample kept:
    the other branches of the controller, lane by lane."""
    options = Options(control="hairer", hmax=0.05, rtol=1e-6, atol=1e-9)
    check("four_pendula", ADAPTIVE, "portable", options=options)


@pytest.mark.parametrize("name", ["three_bodies", "double_pendulum"])
def test_adaptive_native(name: str) -> None:
    """The same under -O3 -march=native (contraction off in both builds)."""
    check(name, ADAPTIVE, "native")


def _shared_h(c: str, upper: str) -> str:
    """rk45's stages take lane 0's step size on every lane."""
    line = "yn[e] = y[e] + hl[l] * acc;"  # one per stage
    return edited(c, line, "yn[e] = y[e] + hl[0] * acc;", times=6)


def _rejected_accepted(c: str, upper: str) -> str:
    """A rejected rk45 step still advances its lane (the error test never fails)."""
    return edited(c, "if (!(err <= 1.0)) {", "if (!(err <= 1.0) && 0) {")


def _dense_everywhere(c: str, upper: str) -> str:
    """dop853's extension stages run (and count) on every accepted lane."""
    return edited(c, "_batch_field_on(b, dense, yt,", "_batch_field_on(b, acc, yt,", times=3)


@pytest.mark.parametrize(
    ("broken", "method"),
    [(_shared_h, "rk45"), (_rejected_accepted, "rk45"), (_dense_everywhere, "dop853")],
)
def test_broken_lanes_are_caught(broken, method: str) -> None:  # type: ignore[no-untyped-def]
    """Each lane's own h, its rejections and its masks matter: a broken variant fails the
    comparison on the four pendula."""
    s = system("four_pendula")
    files = dict(emit(s.with_batch(), "c"))
    source = f"{s.name}.c"
    files[source] = broken(files[source], s.name.upper())
    with pytest.raises(AssertionError, match=f"four_pendula {method} member"):
        check("four_pendula", (method,), "portable", files=files)


@pytest.mark.slow
@pytest.mark.parametrize("opt", ["portable", "native"])
@pytest.mark.parametrize(
    "name",
    [
        "four_pendula",
        "dipoles",
        "springs4",
        "pendulum_chain",
        "chain4",
        "rope:n=10",
        "rope:n=10,solver=dense",
        "banded",
    ],
)
def test_adaptive_every_system_both_flag_sets(name: str, opt: str) -> None:
    """rk45 and dop853 on the other systems of test_batch (every way dV/dq and the field run:
    in loops over the lanes, lane by lane, a dense, max-index or banded M), -O2 and -O3
    -march=native."""
    check(name, ADAPTIVE, opt)
