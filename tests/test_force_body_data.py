"""Per-body data ([data]) in force terms: a [[forces.body]] term reads a body's entry as c, a
[[forces.pair]] term as ci and cj, for every selection the force terms take.

Independent checks only: the same forces written with per-member data (one value per listed
body or pair, computed here from the per-body arrays) run the same trajectory in the
reference integrator, which the per-body spelling matches on C, NumPy and the reference; the
energy balance E - E0 - W of a dissipative system converges at the method's order and its work
never grows; a force given as SymPy entries equals the one given as a string; the cache tells
two systems apart by their data alone; clashes and unknown names are one-line errors.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pytest
import sympy as sp

import s2gen
from s2gen.reference.driven_system import driven_problem_from_system
from s2gen.reference.forced_integrate import integrate_driven
from s2gen.spec import define_system, load_spec_text
from s2gen.system import SpecError, System

N = 4
RNG = np.random.default_rng(5)
DAMP = [0.3, 0.1, 0.5, 0.2]
JOINT = [0.4, 1.1, 0.7, 0.9]
ARM = RNG.normal(scale=0.2, size=(N, 3)).round(6).tolist()
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.8, size=(N, 3)))
#: The same forces per body ([data]) and per member (data written out per body or pair)
BODY_F = "-c*cross(w, q) + tau*cross(r, q)"
MEMBER_F = "-cb*cross(w, q) + tau*cross(rb, q)"
PAIR_FI, PAIR_FJ = "cross(ki*kj*(wj - wi), qi) + cross(ri - rj, qj)", "cross(-ki*kj*(wj - wi), qj)"
LIST_FI, LIST_FJ = "cross(kk*(wj - wi), qi) + cross(d, qj)", "cross(-kk*(wj - wi), qj)"


def _pairs(select: Any) -> list[list[int]]:
    """The pairs (1-based) of a pair selection, in its loop order."""
    if isinstance(select, list):
        return select
    chain = [[i, i + 1] for i in range(1, N)]
    if select == "all":
        return [[i, j] for i in range(1, N + 1) for j in range(i + 1, N + 1)]
    return chain + [[N, 1]] if select == "ring" else chain


def _system(bodies: Any, pairs: Any, per_body: bool, name: str) -> System:
    """Four bodies (diagonal M) under gravity and a chain coupling, driven by damping and an
    input torque on `bodies` and by joint damping and offset forces on `pairs`; the data read
    per body, or per member (the products and differences of the per-body values)."""
    common: dict[str, Any] = {
        "bodies": N,
        "parameters": {"g": 1.0, "s": 0.5},
        "diagonal": [f"1 + {b}/10" for b in range(N)],
        "body_terms": [{"V": "g*q[2]"}],
        "pair_terms": [{"V": "s*dot(qi, qj)", "pairs": "chain"}],
        "inputs": {"tau": 0.2},
        "initial_q": Q0,
        "initial_omega": W0,
        "data": {"c": DAMP, "k": JOINT, "r": ARM},
    }
    if per_body:
        body = {"F": BODY_F, "bodies": bodies}
        pair = {"Fi": PAIR_FI, "Fj": PAIR_FJ, "pairs": pairs}
        return define_system(name=name, force_terms=[body], force_pairs=[pair], **common)
    listed = list(range(1, N + 1)) if bodies == "all" else bodies
    body = {
        "F": MEMBER_F,
        "bodies": listed,
        "data": {"cb": [DAMP[b - 1] for b in listed], "rb": [ARM[b - 1] for b in listed]},
    }
    members = _pairs(pairs)
    data = {
        "kk": [JOINT[i - 1] * JOINT[j - 1] for i, j in members],
        "d": [np.subtract(ARM[i - 1], ARM[j - 1]).tolist() for i, j in members],
    }
    pair = {"Fi": LIST_FI, "Fj": LIST_FJ, "pairs": members, "data": data}
    return define_system(name=name, force_terms=[body], force_pairs=[pair], **common)


def _quiet(system: System, method: str, backend: str, **kwargs: Any) -> s2gen.Trajectory:
    """A run without the energy-balance warning (coarse steps on purpose)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return s2gen.simulate(system, method, backend=backend, **kwargs)


CASES = [
    ("all", "chain"),
    ([1, 3, 4], "ring"),
    ("all", "all"),
    ([4, 2], [[1, 3], [4, 2], [2, 3]]),
]


@pytest.mark.parametrize(
    ("bodies", "pairs"), CASES, ids=["all-chain", "list-ring", "all-all", "list-list"]
)
def test_per_body_data_match_per_member_data(bodies: Any, pairs: Any) -> None:
    """The forces reading [data] (a number and a 3-vector per body, in a body and a pair
    term) against the same forces written with per-member data, run by the reference: the
    same q, omega and work to 1e-12 on C, NumPy and the reference, with inputs that change
    every step."""
    tag = "_".join(x if isinstance(x, str) else "list" for x in (bodies, pairs))
    body = _system(bodies, pairs, True, f"fbd_{tag}")
    member = _system(bodies, pairs, False, f"fmd_{tag}")
    assert [[d.name for d in f.body_data] for f in body.forces] == [["c", "r"], ["k", "r"]]
    h, n = 0.01, 50
    U = np.random.default_rng(1).normal(scale=0.5, size=(n, 1))
    truth = integrate_driven(
        driven_problem_from_system(member), "vi", Q0, W0, h, n, inputs=U, t0=0.0
    )
    ref = integrate_driven(driven_problem_from_system(body), "vi", Q0, W0, h, n, inputs=U, t0=0.0)
    runs = {
        "c": _quiet(body, "vi", "c", h=h, T=n * h, inputs=U),
        "numpy": _quiet(body, "vi", "numpy", h=h, T=n * h, inputs=U),
        "reference": ref,
    }
    assert np.max(np.abs(truth.q[-1] - Q0)) > 0.1  # the run goes somewhere
    for backend, run in runs.items():
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-12, backend
        assert run.work is not None and np.max(np.abs(run.work - truth.work)) < 1e-12, backend


def _damped(per_body: bool) -> System:
    """Joint and body damping only (every coefficient positive): the power is
    -sum c_b |w_b|^2 - sum k_i k_j |w_j - w_i|^2 <= 0 for tangent w."""
    spec = f"""
name = "damped_{"body" if per_body else "member"}"
bodies = {N}
[parameters]
g = 1.0
[data]
c = {DAMP}
k = {JOINT}
[inertia]
diagonal = "1 + i/10"
[[potential.body]]
V = "g*q[2]"
[[potential.pair]]
V = "dot(qi, qj)"
pairs = "ring"
[[forces.body]]
F = "-c*cross(w, q)"
[[forces.pair]]
Fi = "cross(ki*kj*(wj - wi), qi)"
Fj = "cross(-ki*kj*(wj - wi), qj)"
pairs = "ring"
[initial]
q = {Q0.tolist()}
omega = {W0.tolist()}
"""
    if not per_body:
        ring = _pairs("ring")
        kk = [JOINT[i - 1] * JOINT[j - 1] for i, j in ring]
        spec = spec.replace("-c*cross", "-cb*cross").replace("ki*kj", "kk")
        spec = spec.replace(
            "[[forces.pair]]\n", f"[forces.body.data]\ncb = {DAMP}\n[[forces.pair]]\n"
        )
        spec = spec.replace(
            'pairs = "ring"\n[initial]', f"pairs = {ring}\n[forces.pair.data]\nkk = {kk}\n[initial]"
        )
    return load_spec_text(spec, origin=f"damped_{per_body}.toml")


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_energy_balance_of_damping_read_per_body(backend: str) -> None:
    """The damped ring: W never grows, max |E - E0 - W| falls like h^2 for the VI as h halves,
    and the run is the per-member spelling's."""
    system, member = _damped(True), _damped(False)
    runs = [_quiet(system, "vi", backend, h=h, T=2.0) for h in (0.04, 0.02, 0.01)]
    balance = [float(np.max(np.abs(tr.balance))) for tr in runs]  # type: ignore[arg-type]
    assert np.log2(balance[1] / balance[2]) > 2 - 0.5, balance
    fine = runs[-1]
    assert fine.work is not None and fine.work[-1] < -0.05
    assert np.all(np.diff(fine.work) <= 1e-15)
    assert balance[2] < 1e-3 * abs(fine.work[-1])
    again = _quiet(member, "vi", backend, h=0.01, T=2.0)
    assert np.max(np.abs(fine.q - again.q)) < 1e-12
    assert again.work is not None and np.max(np.abs(fine.work - again.work)) < 1e-12


def test_sympy_entries_read_the_data_as_strings_do() -> None:
    """A force given as three SymPy entries in the symbols c, ki, kj is the string's."""
    c, ki, kj = sp.symbols("c ki kj", real=True)
    q = sp.Matrix(sp.symbols("q_0:3", real=True))
    w = sp.Matrix(sp.symbols("w_0:3", real=True))
    qi = sp.Matrix(sp.symbols("qi_0:3", real=True))
    wi, wj = (sp.Matrix(sp.symbols(f"{v}_0:3", real=True)) for v in ("wi", "wj"))
    common: dict[str, Any] = {
        "name": "entries",
        "bodies": N,
        "parameters": {},
        "diagonal": ["1"] * N,
        "potential": 0,
        "data": {"c": DAMP, "k": JOINT},
    }
    strings = define_system(
        force_terms=[{"F": "-c*cross(w, q)"}],
        force_pairs=[{"Fi": "ki*kj*cross(wj - wi, qi)", "Fj": "ki*kj*qi", "pairs": "ring"}],
        **common,
    )
    entries = define_system(
        force_terms=[{"F": list(-c * w.cross(q))}],
        force_pairs=[
            {"Fi": list(ki * kj * (wj - wi).cross(qi)), "Fj": list(ki * kj * qi), "pairs": "ring"}
        ],
        **common,
    )
    assert entries.force_vectors() == strings.force_vectors()
    from s2gen.symbols import q_symbol, w_symbol

    q1 = sp.Matrix([q_symbol(1, a) for a in range(3)])
    w1 = sp.Matrix([w_symbol(1, a) for a in range(3)])
    w2 = sp.Matrix([w_symbol(2, a) for a in range(3)])
    q4 = sp.Matrix([q_symbol(4, a) for a in range(3)])
    by_hand = (
        -DAMP[0] * w1.cross(q1)
        + JOINT[0] * JOINT[1] * (w2 - w1).cross(q1)
        + JOINT[3] * JOINT[0] * q4
    )
    at = {s: v for s, v in zip([*q1, *w1, *w2, *q4], np.random.default_rng(2).normal(size=12))}
    error = (strings.force_vectors()[0] - by_hand).xreplace(at)
    assert max(abs(float(e)) for e in error) < 1e-14


def test_the_data_alone_tell_two_systems_apart() -> None:
    """Two systems that differ only in the [data] a force reads have different digests (the
    compile cache keys) and run differently."""
    a = _damped(True)
    spec = a.source.replace(f"c = {DAMP}", f"c = {[2 * v for v in DAMP]}")
    b = load_spec_text(spec, origin="damped_b.toml")
    assert a.spec_digest() != b.spec_digest()
    ra, rb = (_quiet(s, "vi", "c", h=0.02, T=0.4) for s in (a, b))
    assert np.max(np.abs(ra.q - rb.q)) > 1e-4


SPEC = f"""name = "p"
bodies = {N}
[parameters]
g = 1.0
[data]
c = {DAMP}
[inertia]
diagonal = "1"
[potential]
V = "g*q1[2]"
"""


@pytest.mark.parametrize(
    ("before", "after", "fragment"),
    [
        ("", '[[forces.body]]\nF = "-ci*cross(w, q)"\n', "[[forces.body]] #1 F: unknown name 'ci'"),
        (
            "",
            '[[forces.pair]]\nFi = "c*qj"\nFj = "c*qi"\n',
            "[[forces.pair]] #1 Fi: unknown name 'c'",
        ),
        (
            "",
            '[[forces.body]]\nF = "-c*cross(w, q)"\n[forces.body.data]\nc = [1, 2, 3, 4]\n',
            "[[forces.body]] #1 data.c: 'c' is also a per-body datum of [data]",
        ),
        (
            "",
            '[[forces.pair]]\nFi = "ci*qj"\nFj = "ci*qi"\n[forces.pair.data]\nci = [1, 2, 3]\n',
            "[[forces.pair]] #1: the [data] array 'c' (read as ci) uses the symbol ci",
        ),
        (
            "[parameters]\ncj = 2.0\n",
            '[[forces.pair]]\nFi = "qj"\nFj = "qi"\n',
            "the symbol cj, which is also the parameter 'cj'",
        ),
        (
            "[inputs]\nci = 0.0\n",
            '[[forces.pair]]\nFi = "qj"\nFj = "qi"\n',
            "[[forces.pair]] #1: the datum name 'ci' is also an input",
        ),
        (
            "[data]\nw = [1, 2, 3, 4]\n",
            '[[forces.body]]\nF = "-c*cross(w, q)"\n',
            "[[forces.body]] #1: the [data] array 'w' is read as w, the angular velocity w",
        ),
    ],
    ids=["body-ci", "pair-c", "body-data", "pair-data", "parameter", "input", "velocity"],
)
def test_clashes_and_unknown_names_are_one_line_errors(
    before: str, after: str, fragment: str
) -> None:
    table = before.partition("\n")[0]
    text = SPEC.replace(f"{table}\n", before, 1) if table and table in SPEC else SPEC + before
    with pytest.raises(SpecError) as info:
        load_spec_text(text + after, origin="p.toml")
    message = str(info.value)
    assert "\n" not in message and message.startswith("p.toml: ") and fragment in message
