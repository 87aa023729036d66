"""Driven systems in the spec (issue 20): time t in potentials, [inputs] and [forces].

The parsed forces and potentials are compared with the same physics written by hand in SymPy
(the closed forms of a torque, viscous damping and a moving support); the two front doors
(TOML and `define_system`) must give the same System; closed systems are unchanged.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.cli import main
from s2gen.spec import define_system, load_spec_text, parse_expression
from s2gen.symbols import TIME, q_vector, w_vector
from s2gen.systems import builtin, builtin_names, with_parameters

SPEC = """\
name = "driven"
bodies = 2
[parameters]
m = 1.5
g = 9.81
c = 0.2
A = 0.5
Om = 3.0
[inputs]
tau = 0.25
[inertia]
M = [["2*m", "m"], ["m", "m"]]
[potential]
V = "-2*m*g*q1[2] - m*g*q2[2] + m*A*Om**2*cos(Om*t)*q1[0]"
[forces]
F1 = "tau*cross(e3, q1)"
[[forces.body]]
F = "-k*cross(w, q)"
[forces.body.data]
k = ["c", 0.1]
"""

E3 = sp.Matrix([0, 0, 1])


def api_system() -> object:
    return define_system(
        name="driven",
        bodies=2,
        parameters={"m": 1.5, "g": 9.81, "c": 0.2, "A": 0.5, "Om": 3.0},
        inputs={"tau": 0.25},
        inertia=[["2*m", "m"], ["m", "m"]],
        potential="-2*m*g*q1[2] - m*g*q2[2] + m*A*Om**2*cos(Om*t)*q1[0]",
        forces={"F1": "tau*cross(e3, q1)"},
        force_terms=[{"F": "-k*cross(w, q)", "data": {"k": ["c", 0.1]}}],
    )


def test_forces_are_the_torque_and_the_damping_written_by_hand() -> None:
    s = load_spec_text(SPEC, origin="driven.toml")
    tau = sp.Symbol("tau", real=True)
    q1, q2, w1, w2 = q_vector(1), q_vector(2), w_vector(1), w_vector(2)
    expected = [tau * E3.cross(q1) - 0.2 * w1.cross(q1), -0.1 * w2.cross(q2)]
    got = s.force_vectors()
    for body in range(2):
        assert sp.simplify(got[body] - expected[body]) == sp.zeros(3, 1)
    assert s.inputs.names == ("tau",) and s.inputs.values == (0.25,)
    assert s.driven


def test_the_moving_support_potential_holds_time() -> None:
    s = load_spec_text(SPEC, origin="driven.toml")
    m, g, A, Om = sp.symbols("m g A Om", real=True)
    q1, q2 = q_vector(1), q_vector(2)
    support = m * A * Om**2 * sp.cos(Om * TIME) * q1[0]
    expected = -2 * m * g * q1[2] - m * g * q2[2] + support
    assert sp.simplify(s.potential - expected) == 0
    assert sp.diff(s.potential, TIME) != 0


def test_the_two_front_doors_agree() -> None:
    from_toml = load_spec_text(SPEC, origin="driven.toml")
    assert api_system().spec_digest() == from_toml.spec_digest()


def test_the_driven_part_changes_the_digest() -> None:
    """Two systems that differ only in their forces or inputs are not the same system."""
    base = api_system()
    other = define_system(
        name="driven",
        bodies=2,
        parameters={"m": 1.5, "g": 9.81, "c": 0.2, "A": 0.5, "Om": 3.0},
        inputs={"tau": 0.5},
        inertia=[["2*m", "m"], ["m", "m"]],
        potential="-2*m*g*q1[2] - m*g*q2[2] + m*A*Om**2*cos(Om*t)*q1[0]",
        forces={"F1": "tau*cross(e3, q1)"},
        force_terms=[{"F": "-k*cross(w, q)", "data": {"k": ["c", 0.1]}}],
    )
    assert base.spec_digest() != other.spec_digest()


#: The driven built-ins: the damped, periodically forced double pendulum (forces) and
#: Kapitza's pendulum (a time-dependent potential)
DRIVEN_BUILTINS = {"forced_double_pendulum": (True, False), "kapitza": (False, False)}


@pytest.mark.parametrize("name", builtin_names())
def test_builtins_are_closed_unless_named_driven(name: str) -> None:
    s = builtin(name)
    assert s.driven == (name in DRIVEN_BUILTINS)
    forces, inputs = DRIVEN_BUILTINS.get(name, (False, False))
    assert bool(s.forces) == forces and bool(s.inputs.names) == inputs


def test_the_rope_with_a_moving_top_is_driven_by_time_only() -> None:
    s = builtin("rope", n=3, top_radius=0.2)
    assert s.driven and not s.forces and not s.inputs.names
    assert not builtin("rope", n=3).driven


def test_a_parameter_named_t_hides_time() -> None:
    """Specs written before time existed keep their meaning: t is then the parameter."""
    s = define_system(
        name="old", bodies=1, parameters={"t": 2.0}, diagonal=["1"], potential="t*q1[2]"
    )
    assert not s.driven
    s = define_system(
        name="old",
        bodies=2,
        parameters={},
        diagonal=["1", "1"],
        pair_terms=[{"V": "t*dot(qi, qj)", "pairs": "chain", "data": {"t": [3.0]}}],
    )
    assert not s.driven
    s = define_system(
        name="new",
        bodies=2,
        parameters={},
        diagonal=["1", "1"],
        pair_terms=[{"V": "cos(t)*dot(qi, qj)", "pairs": "chain"}],
    )
    assert s.driven


def test_force_terms_on_listed_bodies_with_vector_data() -> None:
    """A force at the point l q_i (F_i = l f) on bodies 1 and 3, f a per-body vector."""
    s = define_system(
        name="push",
        bodies=3,
        parameters={"l": 0.5},
        diagonal=["1", "1", "1"],
        potential=0,
        force_terms=[{"F": "l*f", "bodies": [1, 3], "data": {"f": [[1, 0, 0], [0, 2, 0]]}}],
    )
    got = s.force_vectors()
    assert [list(v) for v in got] == [[0.5, 0, 0], [0, 0, 0], [0, 1.0, 0]]


def test_time_and_velocities_are_numbers_of_the_expression() -> None:
    """The parsed force evaluates like its closed form at a random state and time."""
    s = load_spec_text(SPEC, origin="driven.toml")
    rng = np.random.default_rng(3)
    q = rng.normal(size=(2, 3))
    w = rng.normal(size=(2, 3))
    tau = 0.7
    values = {sp.Symbol("tau", real=True): tau}
    for i in range(2):
        values.update(zip(q_vector(i + 1), q[i]))
        values.update(zip(w_vector(i + 1), w[i]))
    got = np.array([[float(e.xreplace(values)) for e in v] for v in s.force_vectors()])
    e3 = np.array([0.0, 0.0, 1.0])
    expected = np.array(
        [tau * np.cross(e3, q[0]) - 0.2 * np.cross(w[0], q[0]), -0.1 * np.cross(w[1], q[1])]
    )
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-14)


def test_new_parameter_values_keep_the_driven_part() -> None:
    s = define_system(
        name="damped",
        bodies=1,
        parameters={"c": 0.2},
        inputs={"u": 1.0},
        diagonal=["1"],
        potential="-u*q1[2]",
        forces={"F1": "-c*cross(w1, q1)"},
    )
    changed = with_parameters(s, {"c": 0.4})
    assert changed.inputs == s.inputs and changed.forces == s.forces
    w1 = w_vector(1)
    assert sp.expand(changed.force_vectors()[0] - s.force_vectors()[0]) == sp.expand(
        -0.2 * w1.cross(q_vector(1))
    )


def test_time_is_a_name_of_potentials_only() -> None:
    V = parse_expression("cos(t)*q1[2]", n=1, parameters=[], where="x")
    assert V == sp.cos(TIME) * q_vector(1)[2]


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (
            ["generate", "--lang", "numpy", "--out", "OUT"],
            (
                "[forces] F1: emitting numpy code (sphere form) for driven systems (forces, inputs "
                "or time t) is not supported yet"
            ),
        ),
        (
            ["simulate", "--backend", "numpy", "--h", "0.01", "--T", "0.1", "--out", "OUT"],
            "[forces] F1: emitting numpy code (sphere form) for driven systems",
        ),
        (
            ["simulate", "--method", "rattle", "--h", "0.01", "--T", "0.1", "--out", "OUT"],
            "method 'rattle' takes forces only with a diagonal inertia yet",
        ),
    ],
)
def test_the_command_line_refuses_what_does_not_drive_yet_in_one_line(
    args: list[str], fragment: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """What does not take driven systems yet (the NumPy backend, RATTLE): exit 2, one line
    naming the file (and the first driven key or the method), nothing written."""
    spec = tmp_path / "driven.toml"
    spec.write_text(
        SPEC + "[initial]\nq = [[0, 0, 1], [1, 0, 0]]\nomega = [[0, 1, 0], [0, 0, 1]]\n"
    )
    out = tmp_path / "out"
    code = main([args[0], str(spec), *[str(out) if a == "OUT" else a for a in args[1:]]])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"error: {spec}: ")
    assert fragment in err
    assert not out.exists()


def test_the_command_line_simulates_a_driven_spec_with_its_inputs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--input NAME=EXPR is the expression at the start of each step, --t0 the start time; the
    saved trajectory keeps the inputs and the work, and the report the balance."""
    spec = tmp_path / "driven.toml"
    spec.write_text(
        SPEC + "[initial]\nq = [[0, 0, 1], [1, 0, 0]]\nomega = [[0, 1, 0], [0, 0, 1]]\n"
    )
    out = tmp_path / "run.npz"
    args = ["simulate", str(spec), "--h", "0.01", "--T", "0.1", "--t0", "1.0"]
    code = main([*args, "--input", "tau=2*t + A", "--param", "A=0.5", "--out", str(out)])
    report = capsys.readouterr().out
    assert code == 0 and "|E - E0 - W|" in report and "work W(T)" in report
    from s2gen.runtime.trajectory import Trajectory

    tr = Trajectory.load(out)
    assert np.allclose(tr.t, 1.0 + 0.01 * np.arange(11), rtol=0, atol=1e-12)
    assert tr.inputs is not None and tr.work is not None
    assert np.allclose(tr.inputs[:, 0], 2 * (1.0 + 0.01 * np.arange(10)) + 0.5, rtol=0, atol=1e-12)
