"""NumPy's integrate_batch(): each member integrate()'s for that member, failures alone.

The reference is the NumPy module's integrate() called once per member: every member's
samples q and omega, its energy, its status and every field of its statistics must be equal
as raw doubles (uint64), bit for bit. That holds although the batch works on all members at
once: every operation is elementwise over the member axis, the sums over a term's members or
the bodies run over each member's own contiguous row as integrate()'s numpy.sum does, and a
dense M's solves (Newton's and the velocities', the field's) are LAPACK's on each member's
own matrix. The batch holds K = 11 members, each with its own parameters and initial state;
one has a NaN in q0 (fails before its first sample), one a body 1.001 long (refused,
ERR_ARGUMENT, with that body's number), one an angular velocity so large that
its first step fails (infeasible for the VI, not finite for Runge-Kutta or Newton) and, with
a dense M, one spins 10^4 times faster, so that RK4 meets a singular A(q) in a stage after
its first step (ERR_SINGULAR), and one starts upside down at rest under a far stronger
gravity, so that its Newton iteration fails some steps in (ERR_NEWTON) while the others,
iterating their own number of times, go on. The C backend's integrate_batch() (an
independent implementation, in C with lanes) must agree with every member to 1e-10, the
same members failing at the same samples. Three broken variants of the emitted module (every
member stops when one fails; every member gets member 0's constants; a member whose Newton
converged goes on iterating while others do) must fail the comparison.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np
import pytest

from s2gen.emit import emit
from s2gen.runtime.batch import Batch, integrate_batch
from s2gen.runtime.batch_numpy import integrate_batch_numpy, numpy_batch_methods
from s2gen.runtime.c import CBackend
from s2gen.runtime.model import Model
from s2gen.runtime.numpy_module import NumpyBackend, import_cached
from s2gen.runtime.options import Options
from s2gen.systems import builtin

K, H, NSTEPS, EVERY = 11, 0.01, 40, 4
NAN_MEMBER, FAST_MEMBER, SPIN_MEMBER, LATE_MEMBER, LONG_MEMBER = 3, 9, 1, 6, 5
VI = ("vi", "vi4", "vi6", "vi8")
RK = ("rk2", "rk2-proj", "rk3", "rk4")


def members(name: str, spin: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K perturbed copies of the spec's state and parameters (each parameter of each member
    its own), three made to fail at once (a NaN, a body 1.001 long, a huge velocity), and with `spin` SPIN_MEMBER 10^4 times faster and
    LATE_MEMBER upside down at rest under a gravity 10^3 times stronger."""
    s = builtin(name)
    rng = np.random.default_rng(11)
    q0 = s.q0[None] + 1e-2 * rng.standard_normal((K, s.n, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = s.omega0[None] + 0.1 * rng.standard_normal((K, s.n, 3))
    w0 -= np.sum(w0 * q0, axis=2, keepdims=True) * q0
    p = np.array(s.parameter_values)[None] * (1 + 0.2 * rng.random((K, len(s.parameter_values))))
    q0[NAN_MEMBER, 0, 1] = np.nan
    q0[LONG_MEMBER, 1] *= 1.001
    w0[FAST_MEMBER] *= 1e170
    if spin:
        w0[SPIN_MEMBER] *= 1e4
        q0[LATE_MEMBER] = -s.q0 + 1e-3
        q0[LATE_MEMBER] /= np.linalg.norm(q0[LATE_MEMBER], axis=1, keepdims=True)
        w0[LATE_MEMBER] = 0.0
        p[LATE_MEMBER, s.parameter_names.index("g")] *= 1e3
    return q0, w0, p


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.uint64)


def compare(
    name: str,
    methods: tuple[str, ...],
    batched: NumpyBackend,
    spin: bool = False,
    options: Options | None = None,
) -> dict[str, Batch]:
    """Every member of the NumPy batch against the NumPy integrate() of that member alone,
    bit for bit, both with `options` (default Options()); the batches by method."""
    one, opts = NumpyBackend(builtin(name)), options or Options()
    q0, w0, p = members(name, spin)
    out = {}
    for m in methods:
        b = integrate_batch_numpy(batched, m, H, NSTEPS, q0, w0, p, opts, EVERY)
        assert b.energy is not None and b.q.shape == (K, NSTEPS // EVERY + 1, one.system.n, 3)
        for k in range(K):
            status, q, w, e, stats = one.integrate(m, H, NSTEPS, q0[k], w0[k], p[k], opts, EVERY)
            where = f"{name} {m} member {k}"
            assert int(b.status[k]) == status, where
            assert {f: v[k].item() for f, v in b.stats.items()} == stats, where
            assert np.array_equal(bits(b.q[k]), bits(q)), where  # NaN past a failure in both
            assert np.array_equal(bits(b.omega[k]), bits(w)), where
            assert np.array_equal(bits(b.energy[k]), bits(e)), where
        assert b.status[NAN_MEMBER] == 3 and b.stats["fail_step"][NAN_MEMBER] == 0, m
        assert b.status[LONG_MEMBER] == 4 and b.stats["fail_body"][LONG_MEMBER] == 1, m
        assert b.status[FAST_MEMBER] != 0 and b.stats["fail_step"][FAST_MEMBER] == 1, m
        out[m] = b
    return out


def against_c(name: str, batches: dict[str, Batch], spin: bool = False) -> None:
    """The C backend's integrate_batch() of the same members: the same members fail at the
    same samples, and the samples and energies of every member agree to 1e-10 while it runs.
    The cause of the spinning member's failure is not compared: its state blows up within a
    step, and C's own LU reports the non-finite result (ERR_NONFINITE) where LAPACK's finds
    the matrix singular first (ERR_SINGULAR), as their integrate() do one member at a time.
    Nor are the samples of the spinning and the upside-down member: they grow without bound
    (to 1e36 under RK2), so that the last bits' differences grow with them."""
    c = CBackend(builtin(name).with_batch())
    q0, w0, p = members(name, spin)
    for m, b in batches.items():
        cb = integrate_batch(c, m, H, NSTEPS, q0, w0, p, Options(), EVERY)
        assert np.array_equal(cb.status != 0, b.status != 0), m
        first = [NAN_MEMBER, FAST_MEMBER, LONG_MEMBER]
        assert np.array_equal(cb.status[first], b.status[first]), m
        assert np.array_equal(cb.stats["fail_step"], b.stats["fail_step"]), m
        for k in sorted(set(range(K)) - ({SPIN_MEMBER, LATE_MEMBER} if spin else set())):
            done = int(b.stats["fail_step"][k])
            for x, y in ((cb.q, b.q), (cb.omega, b.omega)):
                assert np.allclose(x[k, :done], y[k, :done], rtol=0, atol=1e-10, equal_nan=True), (
                    m,
                    k,
                )
            assert cb.energy is not None and b.energy is not None
            e = b.energy[k, :done]
            scale = max(1.0, float(np.max(np.abs(e[np.isfinite(e)]), initial=0.0)))
            assert np.allclose(
                cb.energy[k, :done], b.energy[k, :done], rtol=0, atol=1e-10 * scale, equal_nan=True
            )


@pytest.mark.parametrize("name", ["four_pendula", "three_bodies"])
def test_explicit_every_method(name: str) -> None:
    """A diagonal M (four pendula: body and listed terms with member tables; three bodies:
    pair terms reading the parameters): the VI family and every fixed-step RK."""
    batched = NumpyBackend(builtin(name).with_batch())
    assert numpy_batch_methods(batched) == VI + RK
    against_c(name, compare(name, VI + RK, batched))


def test_dense_every_method() -> None:
    """A dense M and a general potential (the double pendulum): the Newton VI family, each
    member iterating under its own mask (its own count, its own warm start; LATE_MEMBER's
    Newton fails some steps in, ERR_NEWTON, alone), and every fixed-step RK (a member's
    singular stage, ERR_SINGULAR, alone)."""
    batched = NumpyBackend(builtin("double_pendulum").with_batch())
    assert numpy_batch_methods(batched) == VI + RK
    batches = compare("double_pendulum", VI + RK, batched, spin=True)
    assert batches["rk4"].status[SPIN_MEMBER] == 6
    assert 0 < batches["rk4"].stats["steps"][SPIN_MEMBER] < NSTEPS  # after a step, not at once
    for m in VI:
        b = batches[m]
        assert b.status[LATE_MEMBER] == 2 and 0 < b.stats["steps"][LATE_MEMBER] < NSTEPS, m
    iters = batches["vi"].stats["newton_iters"][batches["vi"].status == 0]
    assert len(set(iters.tolist())) > 1  # the members that go on took counts of their own
    against_c("double_pendulum", batches, spin=True)


def test_dense_terms_with_tables() -> None:
    """A dense M with terms and their member tables (the pendulum chain): the VI and RK4."""
    compare("pendulum_chain", ("vi", "rk4"), NumpyBackend(builtin("pendulum_chain").with_batch()))


def test_newton_limit_fails_alone() -> None:
    """With newton_maxiter = 3, the members that need more iterations in a substep fail at
    the limit (ERR_NEWTON) alone, as integrate() does for each."""
    batches = compare(
        "double_pendulum",
        ("vi4",),
        NumpyBackend(builtin("double_pendulum").with_batch()),
        spin=True,
        options=Options(newton_maxiter=3),
    )
    status = batches["vi4"].status
    assert (status == 2).sum() > 1 and (status == 0).any()


def _stop_all(text: str) -> str:
    """Every member stops as soon as one fails."""
    return text.replace(
        "        keep = status == OK\n", "        keep = (status == OK) & numpy.all(status == OK)\n"
    )


def _shared_constants(text: str) -> str:
    """Every member runs with member 0's constants (masses, cc, parameters, tables)."""
    return text.replace("for c in each]", "for c in each[:1] * len(each)]")


class _Broken(NumpyBackend):
    def __init__(self, name: str, edit: Callable[[str], str]) -> None:
        self.system = builtin(name).with_batch()
        ((fname, text),) = emit(self.system, "numpy").items()
        changed = edit(text)
        assert changed != text
        self.module = import_cached(re.sub(r"\.py$", "_broken.py", fname), changed)


def _converged_go_on(text: str) -> str:
    """A member whose Newton converged goes on iterating until every member's has."""
    return text.replace(
        "        active[a[fail | done]] = False\n",
        "        active[a[fail]] = False\n"
        "        active &= not numpy.all(converged | ~running | (status != OK))\n",
    )


@pytest.mark.parametrize(
    ("name", "edit"),
    [
        ("four_pendula", _stop_all),
        ("four_pendula", _shared_constants),
        ("double_pendulum", _converged_go_on),
    ],
)
def test_broken_variants_are_caught(name: str, edit: Callable[[str], str]) -> None:
    """A batch whose members stop together, share member 0's constants, or whose converged
    members go on iterating is not integrate() member by member."""
    broken = _Broken(name, edit)
    with pytest.raises(AssertionError, match=f"{name} vi member"):
        compare(name, ("vi",), broken)


def test_model_integrate_batch() -> None:
    """Model(system, backend="numpy").integrate_batch: parameters by name, the spec's state
    by default, the C backend's record; a member's run equals Model.integrate's."""
    model = Model(builtin("four_pendula"), "numpy")
    b = model.integrate_batch("vi4", h=0.01, T=0.2, params={"g": [9.0, 9.5, 10.0]}, every=4)
    assert isinstance(b, Batch) and b.q.shape == (3, 6, 4, 3) and b.omega.shape == b.q.shape
    assert b.energy is not None and b.energy.shape == (3, 6)
    tr = model.integrate("vi4", h=0.01, T=0.2, params={"g": 9.5}, every=4)
    assert np.array_equal(bits(b.q[1]), bits(tr.q)) and np.array_equal(b.t, tr.t)
    assert np.array_equal(bits(b.energy[1]), bits(tr.energy))
    none = model.integrate_batch("rk4", h=0.01, T=0.1, params={"g": [1.0, 2.0]}, energy=False)
    assert none.energy is None and (none.status == 0).all()


def test_refusals() -> None:
    """What the NumPy batch does not cover is refused in one line: a method that is not
    batched, quadratic terms, a structured M, a driven system."""
    four = Model(builtin("four_pendula"), "numpy")
    for m in ("rk45", "rattle", "dop853"):
        with pytest.raises(ValueError, match=f"method '{m}' is not batched on the NumPy backend"):
            four.integrate_batch(m, h=0.01, T=0.1, params={"g": [1.0, 2.0]})
    for name, why in (("dipoles", "no quadratic terms"), ("rope", "diagonal or dense M")):
        q0 = np.repeat(builtin(name).q0[None], 2, axis=0)
        with pytest.raises(ValueError, match=f"{name}: integrate_batch.. on the NumPy .*{why}"):
            Model(builtin(name), "numpy").integrate_batch("rk4", h=0.01, T=0.1, q0=q0)
    with pytest.raises(ValueError, match="closed systems; this one is driven"):
        Model(builtin("forced_double_pendulum"), "numpy").integrate_batch("vi", h=0.01, T=0.1)
