"""A driven system's integrate_batch(): each member bit for bit integrate()'s for that member.

The reference is the plain module's driven integrate() (the module without integrate_batch(),
built with the same flags), called once per member with the member's parameters, initial
state and input schedule: every member's samples q and omega, its energy, its work W, its
status and every field of its statistics must be equal as raw doubles (compared as uint64).
The batch holds K = 11 members (not a multiple of 8, so one block of 8 and a partial one),
every member with its own parameters and initial state and, on the spec with inputs, its own
input schedule, from t0 != 0. Two members fail: one with a NaN in q0 (before its first
sample) and one with an angular velocity so large that its first step fails; on the spec
with inputs a third holds a NaN input from step 17 on (ERR_NONFINITE there, the samples
before it kept). Their neighbours must not notice. Systems: forced_double_pendulum (a coupled
M, forces of the state and of t), kapitza (a diagonal M, a potential of t) and `SPIN` below (a
diagonal M, two inputs: a torque and the strength of a coupling in V, whose changes are work);
the test specs driven_double (a coupled M with inputs) and driven_ring (inputs, force terms).
Two broken variants of the emitted C (every member reads member 0's inputs; the jumps of V
where an input changes are not booked as work) must fail the comparison.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from variants import edited

from s2gen.emit import emit
from s2gen.methods import driven_methods
from s2gen.runtime.batch_driven import integrate_driven_batch, member_inputs
from s2gen.runtime.c import CBackend
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.spec import define_system
from s2gen.system import System
from s2gen.systems import builtin, resolve

K, H, NSTEPS, EVERY, T0 = 11, 0.01, 60, 6, 0.37
SPECS = Path(__file__).parent / "specs"
SYSTEMS = ("forced_double_pendulum", "kapitza", "driven_pair", "driven_double", "driven_ring")
NAN_MEMBER, FAST_MEMBER, INPUT_MEMBER, INPUT_STEP = 3, 9, 5, 17

#: Two bodies, a diagonal M, two inputs: tau (a torque on body 1) and a (a coupling in V)
SPIN = define_system(
    name="driven_pair",
    bodies=2,
    parameters={"k": 1.5, "g": 9.81},
    inputs={"tau": 0.5, "a": 1.0},
    diagonal=["1", "2"],
    potential="a*k*dot(q1, q2) - g*q1[2]",
    forces={"F1": "tau*cross(e3, q1)"},
    initial_q=[[0.6, 0.0, 0.8], [0.0, 0.6, 0.8]],
    initial_omega=[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
)


def system(name: str) -> System:
    """`SPIN`, a spec of tests/specs (driven_double: a coupled M and inputs; driven_ring: a
    diagonal M, inputs and force terms) or a built-in."""
    if name in ("driven_double", "driven_ring"):
        return resolve(str(SPECS / f"{name}.toml"))
    return SPIN if name == "driven_pair" else builtin(name)


def methods(s: System) -> tuple[str, ...]:
    return driven_methods(rattle=not s.forces or s.is_diagonal)


def members(s: System) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """K perturbed copies of the spec's state and parameters, each with its own inputs (a
    random schedule around the defaults), two or three of them made to fail."""
    rng = np.random.default_rng(11)
    q0 = s.q0[None] + 1e-2 * rng.standard_normal((K, s.n, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = s.omega0[None] + 0.1 * rng.standard_normal((K, s.n, 3))
    w0 -= np.sum(w0 * q0, axis=2, keepdims=True) * q0
    p = np.array(s.parameter_values)[None] * (1 + 0.2 * rng.random((K, len(s.parameter_values))))
    q0[NAN_MEMBER, 0, 1] = np.nan
    w0[FAST_MEMBER] *= 1e170
    u = None
    if s.inputs.names:
        defaults = np.array([float(v) for v in s.inputs.values])
        u = defaults * (1 + 0.5 * rng.standard_normal((K, NSTEPS, len(defaults))))
        u[INPUT_MEMBER, INPUT_STEP:, 0] = np.nan
    return q0, w0, p, u


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.uint64)


def check(
    name: str,
    chosen: tuple[str, ...] | None = None,
    opt: str | None = "portable",
    files: dict[str, str] | None = None,
) -> None:
    """Every member of the batch against integrate() of that member alone (`files`: the
    batched module's C, by default the emitted one)."""
    s = system(name)
    one, batched = CBackend(s, opt=opt), CBackend(s.with_batch(), files, opt=opt)
    assert not one.library.batch and batched.library.batch
    q0, w0, p, u = members(s)
    ui = member_inputs(s, u, K, NSTEPS)
    assert K % 8 != 0
    for m in chosen or methods(s):
        b = integrate_driven_batch(batched, m, T0, H, NSTEPS, q0, w0, p, ui, Options(), EVERY)
        assert b.energy is not None and b.W is not None
        for k in range(K):
            status, q, w, e, W, stats = one.integrate_driven(
                m, H, NSTEPS, q0[k], w0[k], p[k], Options(), T0, None if u is None else u[k], EVERY
            )
            done = int(stats["fail_step"]) if status else q.shape[0]
            where = f"{name} {m} member {k}"
            assert int(b.status[k]) == status, where
            assert {
                f: int(v[k]) if f != "fail_time" else float(v[k]) for f, v in b.stats.items()
            } == stats, where
            for got, want in ((b.q[k], q), (b.omega[k], w), (b.energy[k], e), (b.W[k], W)):
                assert np.array_equal(bits(got[:done]), bits(want[:done])), where
                assert np.isnan(got[done:]).all(), where  # nothing written past a failure
        failing = (NAN_MEMBER, FAST_MEMBER) + ((INPUT_MEMBER,) if u is not None else ())
        ok = [k for k in range(K) if k not in failing]
        assert (b.status[ok] == 0).all() and b.status[NAN_MEMBER] == 3, m
        assert b.status[FAST_MEMBER] != 0 and b.stats["fail_step"][FAST_MEMBER] == 1, m
        if u is not None:  # the NaN input stops the member at its step, the samples kept
            assert b.status[INPUT_MEMBER] == 3, m
            assert b.stats["fail_step"][INPUT_MEMBER] == INPUT_STEP // EVERY + 1, m
        assert np.array_equal(b.t, T0 + H * EVERY * np.arange(NSTEPS // EVERY + 1))


@pytest.mark.parametrize("name", SYSTEMS)
def test_every_method(name: str) -> None:
    check(name)


@pytest.mark.slow
@pytest.mark.parametrize("name", SYSTEMS)
def test_every_method_native(name: str) -> None:
    check(name, opt="native")


def _inputs_of_member0(c: str, upper: str) -> str:
    """Every member reads member 0's input schedule."""
    return edited(
        c,
        f"ub[j] = u[(i * {upper}_NINPUTS + j) * K + k];",
        f"ub[j] = u[(i * {upper}_NINPUTS + j) * K];",
    )


def _jumps_unbooked(c: str, upper: str) -> str:
    """The jumps of V where a member's input changes are not counted as work (the one-member
    integrate() keeps its own, unbroken)."""
    at = c.index("_batch_member(")
    jump = "done += driven_pair_potential_cx(cx, qk) - before;"
    assert c[at:].count(jump) == 1
    return c[:at] + c[at:].replace(jump, "(void)before;")


@pytest.mark.parametrize("broken", [_inputs_of_member0, _jumps_unbooked])
def test_broken_variants_are_caught(broken: Callable[[str, str], str]) -> None:
    """Each member must read its own inputs and book the work of their changes: either broken
    variant fails the comparison on the spec with inputs."""
    files = dict(emit(SPIN.with_batch(), "c"))
    source = f"{SPIN.name}.c"
    files[source] = broken(files[source], SPIN.name.upper())
    with pytest.raises(AssertionError, match="driven_pair vi member"):
        check("driven_pair", ("vi",), files=files)


def test_model_integrate_batch() -> None:
    """Model.integrate_batch with inputs per member and one schedule for all: each member's
    record equals Model.integrate's with its inputs, t and the work W included."""
    model = Model(SPIN)
    u = np.stack([np.full((20, 2), 0.5 + 0.25 * k) for k in range(3)])
    u[:, 10:, 1] = 2.0  # a coupling that changes halfway: its jump is work
    b = model.integrate_batch(
        "rk4", h=0.01, T=0.2, params={"k": [1.0, 2.0, 3.0]}, every=4, t0=1.0, inputs=u
    )
    assert b.q.shape == (3, 6, 2, 3) and b.W is not None and b.W.shape == (3, 6)
    for k in range(3):
        tr = model.integrate(
            "rk4", h=0.01, T=0.2, params={"k": 1.0 + k}, every=4, t0=1.0, inputs=u[k]
        )
        assert np.array_equal(bits(b.q[k]), bits(tr.q)) and np.array_equal(b.t, tr.t)
        assert np.array_equal(bits(b.W[k]), bits(tr.work))
    assert np.all(b.W[:, -1] != 0.0)
    same = model.integrate_batch("vi", h=0.01, T=0.2, params={"k": [1.0, 2.0]}, inputs=u[1])
    alone = model.integrate("vi", h=0.01, T=0.2, params={"k": 2.0}, inputs=u[1])
    assert np.array_equal(bits(same.q[1]), bits(alone.q))
    assert np.array_equal(bits(same.energy[1]), bits(alone.energy))


def test_refusals() -> None:
    """In one line: state feedback, a schedule of another shape, the NumPy backend, a closed
    system given inputs or t0, a method that does not integrate the driven system."""
    model = Model(SPIN)
    k2 = {"k": [1.0, 2.0]}
    with pytest.raises(ValueError, match="not state feedback"):
        model.integrate_batch("vi", h=0.01, T=0.1, params=k2, inputs=lambda t, q, w: [0, 1])
    with pytest.raises(ValueError, match=r"inputs of shape \(3, 10, 2\): expected \(10, 2\)"):
        model.integrate_batch("vi", h=0.01, T=0.1, params=k2, inputs=np.zeros((3, 10, 2)))
    with pytest.raises(ValueError, match="t0 = nan"):
        model.integrate_batch("vi", h=0.01, T=0.1, params=k2, t0=float("nan"))
    with pytest.raises(ValueError, match="'rk2-proj' does not integrate driven systems"):
        model.integrate_batch("rk2-proj", h=0.01, T=0.1, params=k2)
    with pytest.raises(ValueError, match="closed systems; this one is driven"):
        Model(SPIN, "numpy").integrate_batch("vi", h=0.01, T=0.1, params=k2)
    with pytest.raises(ValueError, match="is closed: it takes no t0 or inputs"):
        Model(builtin("four_pendula")).integrate_batch(
            "vi", h=0.01, T=0.1, t0=1.0, params={"g": [1.0, 2.0]}
        )
