"""Per-body data combined into a term's member table (`s2gen.passes.hoist.member_data`).

A Lennard-Jones bond between two species with the Lorentz-Berthelot mixing rules, eps_ij =
sqrt(e_i e_j) and sigma_ij = (s_i + s_j) / 2, written with per-body arrays and written with the
mixed values precomputed per pair (the term's own data): on a list of pairs, the chain, and the
ring with a per-pair weight, the two spellings run the same trajectory in C, NumPy and the
reference, and their kernels cost the same per evaluation (the mixing rule is computed once
per member and call). Each member of a batch reads its own lane's table: bit for bit what
integrate() gives that member alone, and the NumPy batch, which takes terms reading per-body
data only through their tables, agrees with it. Rows and cutoff terms keep reading per-body
data per evaluation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from s2gen.ir import Kernel
from s2gen.parts.batch import numpy_batch_refusal
from s2gen.passes import lower_system
from s2gen.runtime import get_backend, simulate
from s2gen.runtime.batch import integrate_batch
from s2gen.runtime.c import CBackend
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options
from s2gen.spec import define_system
from s2gen.system import System

N = 7
RNG = np.random.default_rng(11)
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.4, size=(N, 3)))
E = [1.0, 0.6, 1.3, 0.8, 1.1, 0.7, 0.9]
S = [0.5, 0.4, 0.45, 0.35, 0.55, 0.3, 0.42]
R2 = "dot(qi - qj, qi - qj)"
PER_BODY = f"k*sqrt(ei*ej)*(((si + sj)/2)**12/({R2})**6 - ((si + sj)/2)**6/({R2})**3)"
PER_PAIR = f"k*eps*(sig**12/({R2})**6 - sig**6/({R2})**3)"
LIST = [[1, 3], [2, 5], [6, 4], [3, 2], [7, 1], [5, 7]]


def _members(pairs: Any) -> list[list[int]]:
    if pairs == "chain":
        return [[i, i + 1] for i in range(1, N)]
    if pairs == "ring":
        return [[i, i % N + 1] for i in range(1, N + 1)]
    return list(pairs)


def _system(pairs: Any, per_body: bool, name: str, weighted: bool = False) -> System:
    """The mixing-rule system over `pairs`; `weighted`: every pair also carries its own
    weight w (per-pair data, combined into the same table)."""
    members = _members(pairs)
    weight = {"w": [1.0 + 0.05 * m for m in range(len(members))]} if weighted else {}
    if per_body:
        term = {"V": ("w*" if weighted else "") + PER_BODY, "pairs": pairs, "data": weight}
    else:
        mixed = {
            "eps": [float(np.sqrt(E[i - 1] * E[j - 1])) for i, j in members],
            "sig": [(S[i - 1] + S[j - 1]) / 2 for i, j in members],
        }
        term = {
            "V": ("w*" if weighted else "") + PER_PAIR,
            "pairs": members,
            "data": {**mixed, **weight},
        }
    if not term["data"]:
        del term["data"]
    data = {"e": E, "s": S} if per_body else {}
    return define_system(
        name=name,
        bodies=N,
        parameters={"k": 0.01},
        diagonal="1 + i/10",
        initial_q=Q0,
        initial_omega=W0,
        pair_terms=[term],
        **({"data": data} if data else {}),
    )


CASES = [(LIST, False), ("chain", False), ("ring", True)]
IDS = ["list", "chain", "ring_weighted"]


@pytest.mark.parametrize(("pairs", "weighted"), CASES, ids=IDS)
def test_per_body_mixing_matches_per_pair_mixing(pairs: Any, weighted: bool) -> None:
    tag = IDS[CASES.index((pairs, weighted))]
    body = _system(pairs, True, f"lb_body_{tag}", weighted)
    pair = _system(pairs, False, f"lb_pair_{tag}", weighted)
    truth = simulate(pair, "vi", "reference", h=0.01, T=0.4)
    for backend in ("c", "numpy", "reference"):
        run = simulate(body, "vi", backend, h=0.01, T=0.4)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-12, backend
        assert run.energy is not None and truth.energy is not None
        assert np.max(np.abs(run.energy - truth.energy)) < 1e-12, backend
    p = np.array(body.parameter_values)
    v = get_backend(pair, "reference")._problem(p).potential(Q0)
    bare = float(get_backend(body, "c").potential(Q0, p))  # no workspace: rows member by member
    assert abs(bare - v) < 1e-12


def _ops(kernel: Any) -> int:
    assert isinstance(kernel, Kernel)
    return kernel.ops_after


@pytest.mark.parametrize(("pairs", "weighted"), CASES, ids=IDS)
def test_per_body_data_cost_what_per_pair_data_cost(pairs: Any, weighted: bool) -> None:
    """The mixing rule leaves the per-evaluation kernels: they read the member's table and no
    per-body array, and take no more operations than the hand-mixed spelling's."""
    body = lower_system(_system(pairs, True, "cost_body", weighted))
    pair = lower_system(_system(pairs, False, "cost_pair", weighted))
    tb, tp = body.terms[0], pair.terms[0]
    assert tb.table > 0 and not tb.rows
    for kind in ("value", "gradient"):
        kb, kp = body.kernel(getattr(tb, kind)), pair.kernel(getattr(tp, kind))
        assert isinstance(kb, Kernel)
        assert not [a.name for a in kb.inputs if a.name.startswith("b_")], kind
        assert _ops(kb) <= _ops(kp), kind


def test_rows_and_cutoff_terms_read_per_body_data_per_evaluation() -> None:
    """All pairs as rows read per-body arrays contiguously, and a cutoff term's members are
    found per call: neither gets a member table."""
    rows = lower_system(_system("all", True, "rows_mix"))
    cut = define_system(
        name="cut_mix",
        bodies=N,
        parameters={"k": 0.01},
        diagonal="1",
        data={"e": E, "s": S},
        pair_terms=[{"V": PER_BODY, "pairs": "all", "cutoff": 1.2}],
    )
    for m in (rows, lower_system(cut)):
        t = m.terms[0]
        gradient = m.kernel(t.gradient)
        assert isinstance(gradient, Kernel)
        assert t.table == 0 and any(a.name.startswith("b_") for a in gradient.inputs), m.name


@pytest.mark.parametrize("method", ["vi", "rk4"])
def test_batch_members_read_their_own_tables(method: str) -> None:
    """Members with their own k, in lanes: each bit for bit its own integrate()."""
    s = _system(LIST, True, "lb_lanes")
    one, batched = CBackend(s, opt="portable"), CBackend(s.with_batch(), opt="portable")
    k = 11
    q0 = np.repeat(Q0[None], k, axis=0) + 1e-3 * RNG.standard_normal((k, N, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = np.cross(q0, RNG.normal(scale=0.4, size=(k, N, 3)))
    p = 0.01 * (1 + RNG.random((k, 1)))
    b = integrate_batch(batched, method, 0.01, 40, q0, w0, p, Options(), 5)
    for m in range(k):
        status, q, w, _, _ = one.integrate(method, 0.01, 40, q0[m], w0[m], p[m], Options(), 5)
        assert status == 0 and int(b.status[m]) == 0
        assert np.array_equal(b.q[m].view(np.uint64), q.view(np.uint64)), m
        assert np.array_equal(b.omega[m].view(np.uint64), w.view(np.uint64)), m


def test_numpy_batch_takes_terms_whose_body_data_are_in_tables() -> None:
    """The NumPy batch covers terms that read per-body data only through their member
    tables: its members agree with the C batch's (each bit for bit its integrate(), above)."""
    s = _system(LIST, True, "lb_numpy").with_batch()
    assert numpy_batch_refusal(lower_system(s)) is None
    k = 5
    q0 = np.repeat(Q0[None], k, axis=0) + 1e-3 * RNG.standard_normal((k, N, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = np.cross(q0, RNG.normal(scale=0.4, size=(k, N, 3)))
    params = {"k": 0.01 * (1 + RNG.random(k))}
    runs = [
        Model(s, backend=be).integrate_batch("vi", h=0.01, T=0.4, q0=q0, omega0=w0, params=params)
        for be in ("c", "numpy")
    ]
    assert (runs[0].status == 0).all() and (runs[1].status == 0).all()
    assert np.max(np.abs(runs[0].q - runs[1].q)) < 1e-12
    assert np.max(np.abs(runs[0].omega - runs[1].omega)) < 1e-12
