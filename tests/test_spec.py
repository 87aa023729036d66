"""Tests of the front doors: TOML specs, the Python API, the safe parser and the built-ins."""

from __future__ import annotations

import dataclasses
import os
import warnings
from importlib.resources import as_file, files
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.methods import NAMES
from s2gen.spec import define_system, load_spec, load_spec_text, parse_expression
from s2gen.symbols import q_symbol
from s2gen.system import RunSettings, SpecError, SpecWarning, System
from s2gen.systems import builtin, builtin_names, resolve

BASE = """\
name = "dp"
bodies = 2
[parameters]
m1 = 1.0
m2 = 1.0
l1 = 9.81
l2 = 9.81
g = 9.81
[inertia]
M = [["(m1+m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]]
[potential]
V = "-(m1+m2)*g*l1*dot(e3, q1) - m2*g*l2*dot(e3, q2)"
[initial]
q = [["sqrt(3)/2", 0, "1/2"], [0, 0, 1]]
omega = [["-sqrt(3)/4", 0, "3/4"], [0, 1, 0]]
[run]
h = 0.01
T = 100
method = "vi"
"""
PARAMS = {"m1": 1.0, "m2": 1.0, "l1": 9.81, "l2": 9.81, "g": 9.81}
m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g", real=True)
W = "spec.toml: [potential] V"


def edit(old: str, new: str, text: str = BASE) -> str:
    """BASE with one exact replacement (fails loudly if `old` is not there)."""
    assert text.count(old) == 1, old
    return text.replace(old, new)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "spec.toml"
    path.write_text(text, encoding="utf-8")
    return path


def spec_error(tmp_path: Path, text: str, *fragments: str) -> str:
    """Load `text` from a file, expect a SpecError naming the file and every fragment."""
    with pytest.raises(SpecError) as info:
        load_spec(write(tmp_path, text))
    message = str(info.value)
    assert message.startswith(str(tmp_path / "spec.toml")), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    return message


def expected_inertia() -> sp.Matrix:
    return sp.Matrix([[(m1 + m2) * l1**2, m2 * l1 * l2], [m2 * l1 * l2, m2 * l2**2]])


def expected_potential() -> sp.Expr:
    e3 = sp.Matrix([0, 0, 1])
    q1 = sp.Matrix([q_symbol(1, c) for c in range(3)])
    q2 = sp.Matrix([q_symbol(2, c) for c in range(3)])
    return -(m1 + m2) * g * l1 * e3.dot(q1) - m2 * g * l2 * e3.dot(q2)


def same(a: System, b: System) -> bool:
    """Equal Systems up to origin, including the (uncompared) initial state."""
    return (
        dataclasses.replace(a, origin="") == dataclasses.replace(b, origin="")
        and np.array_equal(a.q0, b.q0)
        and np.array_equal(a.omega0, b.omega0)
    )


# ---------------------------------------------------------------- the example and built-ins
def test_example_loads_exactly_without_warnings() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", SpecWarning)
        s = builtin("double_pendulum")
    assert (s.name, s.n) == ("double_pendulum", 2)
    assert s.parameters == PARAMS
    assert s.inertia == sp.ImmutableMatrix(expected_inertia())
    assert sp.simplify(s.potential - expected_potential()) == 0
    r3 = np.sqrt(3.0)
    np.testing.assert_allclose(s.q0, [[r3 / 2, 0, 0.5], [0, 0, 1]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.omega0, [[-r3 / 4, 0, 0.75], [0, 1, 0]], rtol=0, atol=1e-15)
    assert s.run == RunSettings(h=0.01, T=100.0, method="vi")
    assert s.origin == "s2gen.systems.examples/double_pendulum.toml"
    assert not s.is_diagonal


def test_example_round_trip_through_file_and_resolve() -> None:
    with as_file(files("s2gen.systems.examples") / "double_pendulum.toml") as path:
        from_file = load_spec(path)
        resolved = resolve(str(path))
    assert from_file.origin == str(path)
    assert same(from_file, builtin("double_pendulum"))
    assert same(resolved, from_file)
    assert same(resolve("double_pendulum"), from_file)


def test_builtin_names_and_unknown_names() -> None:
    assert "double_pendulum" in builtin_names()
    assert builtin_names() == sorted(builtin_names())
    with pytest.raises(SpecError, match="'nope'.*built-ins are: .*double_pendulum"):
        builtin("nope")
    with pytest.raises(SpecError, match="'nope' is neither a spec file.*double_pendulum"):
        resolve("nope")
    with pytest.raises(SpecError, match="missing.toml: no such spec file.*double_pendulum"):
        resolve("missing.toml")


def test_resolve_prefers_an_existing_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "double_pendulum").write_text(edit('name = "dp"', 'name = "mine"'))
    monkeypatch.chdir(tmp_path)
    assert resolve("double_pendulum").name == "mine"


# ---------------------------------------------------------------- TOML vs Python API
def api_system(**overrides: object) -> System:
    kwargs: dict[str, object] = {
        "name": "dp",
        "bodies": 2,
        "parameters": PARAMS,
        "inertia": [["(m1+m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]],
        "potential": "-(m1+m2)*g*l1*dot(e3, q1) - m2*g*l2*dot(e3, q2)",
        "initial_q": [["sqrt(3)/2", 0, "1/2"], [0, 0, 1]],
        "initial_omega": [["-sqrt(3)/4", 0, "3/4"], [0, 1, 0]],
        "run": {"h": 0.01, "T": 100, "method": "vi"},
    }
    kwargs.update(overrides)
    return define_system(**kwargs)  # type: ignore[arg-type]


def test_toml_and_python_api_give_equal_systems(tmp_path: Path) -> None:
    from_toml = load_spec(write(tmp_path, BASE))
    from_api = api_system()
    assert from_api.origin == "<python api>"
    assert same(from_toml, from_api)
    assert same(from_toml, load_spec_text(BASE, origin="x"))


def test_python_api_accepts_sympy_objects(tmp_path: Path) -> None:
    from_toml = load_spec(write(tmp_path, BASE))
    from_sympy = api_system(
        inertia=expected_inertia(),
        potential=expected_potential(),
        initial_q=np.array([[np.sqrt(3) / 2, 0, 0.5], [0, 0, 1]]),
        initial_omega=[[-sp.sqrt(3) / 4, 0, sp.Rational(3, 4)], [0, 1, 0]],
        run=RunSettings(h=0.01, T=100.0, method="vi"),
    )
    assert from_sympy.inertia == from_toml.inertia
    assert sp.simplify(from_sympy.potential - from_toml.potential) == 0
    np.testing.assert_allclose(from_sympy.q0, from_toml.q0, atol=1e-15)
    np.testing.assert_allclose(from_sympy.omega0, from_toml.omega0, atol=1e-15)
    assert from_sympy.run == from_toml.run


def test_python_api_rejects_undeclared_sympy_symbol() -> None:
    k = sp.Symbol("k", real=True)
    with pytest.raises(SpecError, match=r"<python api>: \[potential\] V: depends on k"):
        api_system(potential=k * q_symbol(1, 2))


def test_python_api_errors_name_the_origin() -> None:
    with pytest.raises(SpecError, match=r"^<python api>: \[inertia\]: give exactly one"):
        api_system(inertia=None)
    with pytest.raises(SpecError, match=r"^mine: \[run\] T: expected a positive number"):
        api_system(run={"T": 0}, origin="mine")


def test_python_api_rejects_vector_potential() -> None:
    with pytest.raises(SpecError, match=r"\[potential\] V: the potential is a \(3, 1\) matrix"):
        api_system(potential=sp.Matrix([q_symbol(1, c) for c in range(3)]))


# ---------------------------------------------------------------- the parser
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("q1[0] + 2*q2[2]", q_symbol(1, 0) + 2 * q_symbol(2, 2)),
        ("dot(q1, q2)", sum(q_symbol(1, c) * q_symbol(2, c) for c in range(3))),
        ("norm(q1)", sp.sqrt(sum(q_symbol(1, c) ** 2 for c in range(3)))),
        ("cross(e1, e2)[2] + e3[2]", sp.Integer(2)),
        ("cross(q1, q2)[0]", q_symbol(1, 1) * q_symbol(2, 2) - q_symbol(1, 2) * q_symbol(2, 1)),
        ("(q1 - q2/2)[1]", q_symbol(1, 1) - q_symbol(2, 1) / 2),
        ("-m1*sin(pi/6)**2", -m1 / 4),
        ("Abs(-exp(0)) + log(1) + cos(0) + tan(0)", sp.Integer(2)),
        ("  (m1 +\n q1[2])", m1 + q_symbol(1, 2)),
        ("\n  m1\n  + q1[2]\n", m1 + q_symbol(1, 2)),
    ],
)
def test_parser_builds_the_expected_sympy(text: str, expected: sp.Expr) -> None:
    parsed = parse_expression(text, n=2, parameters=["m1"], where=W)
    assert sp.simplify(parsed - expected) == 0


def test_parser_number_types() -> None:
    def parse(text: str) -> sp.Expr:
        return parse_expression(text, n=1, parameters=[], where=W)

    assert isinstance(parse("2"), sp.Integer)
    assert parse("0.5") == sp.Float(0.5) and isinstance(parse("0.5"), sp.Float)
    assert parse("1/2") == sp.Rational(1, 2)
    assert parse("sqrt(3)/2") == sp.sqrt(3) / 2


def test_parsed_potential_matches_an_independent_expression(tmp_path: Path) -> None:
    parsed = load_spec(write(tmp_path, BASE)).potential
    assert sp.simplify(parsed - expected_potential()) == 0
    assert parsed.free_symbols == {g, l1, l2, m1, m2, q_symbol(1, 2), q_symbol(2, 2)}


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("m1 + 2*foo", ["unknown name 'foo'", "column 8"]),
        ("m1 +\n  foo", ["unknown name 'foo'", "line 2, column 3"]),
        ("q1", ["'q1' is a vector, but a scalar is required"]),
        ("q1*q2", ["'*' cannot multiply two vectors", "column 3"]),
        ("q1**2", ["'**' needs scalars", "column 3"]),
        ("m1 + q1", ["'+' cannot combine a scalar and a vector", "column 4"]),
        ("1/q1", ["cannot divide by a vector"]),
        ("q0[1]", ["no body 'q0'", "column 1"]),
        ("q3[1]", ["no body 'q3'", "q1..q2"]),
        ("True", ["boolean True"]),
        ("m1 < 2", ["comparison 'm1 < 2'"]),
        ("q1[3]", ["index '3' must be a literal 0, 1 or 2", "column 4"]),
        ("q1[-1]", ["index '-1'"]),
        ("q1[0:2]", ["index '0:2'"]),
        ("m1[0]", ["cannot index the scalar 'm1'"]),
        ("sin(x=1)", ["keyword argument 'x=1'", "column 5"]),
        ("'abc'", ["string \"'abc'\""]),
        ("m1 ^ 2", ["operator '^'", "use ** for powers", "column 4"]),
        ("7 // 2", ["operator '//'"]),
        ("1/0", ["division by zero", "column 2"]),
        ("log(0)", ["'log(0)' is not finite"]),
        ("10**10**10", ["too large"]),
        ("1e999", ["'1e999' is not finite"]),
        ("dot(q1)", ["dot() takes 2 argument(s), got 1"]),
        ("sin(q1)", ["sin() argument 1 'q1' must be a scalar"]),
        ("dot(1, q1)", ["dot() argument 1 '1' must be a vector"]),
        ("sin", ["function 'sin' used without a call"]),
        ("m1(2)", ["'m1' is not a known function"]),
        ("m1 +* 2", ["syntax error", "column 5"]),
        ("m1 +\n  2 +* 3", ["syntax error", "line 2, column 6"]),
        ("", ["empty expression"]),
        ("1j", ["complex number '1j'"]),
        ("not m1", ["operator 'not'"]),
        ("e4", ["unknown name 'e4'"]),
        ("E", ["unknown name 'E'"]),
    ],
)
def test_parser_errors_name_where_token_and_column(text: str, fragments: list[str]) -> None:
    with pytest.raises(SpecError) as info:
        parse_expression(text, n=2, parameters=["m1"], where=W)
    message = str(info.value)
    assert message.startswith(W + ": "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


@pytest.mark.parametrize(
    ("text", "token"),
    [
        ("__import__('os').system('touch /tmp/s2gen-pwned')", "__import__('os').system"),
        ("q1.__class__", "q1.__class__"),
        ("(lambda: 1)()", "lambda: 1"),
        ("[x for x in q1]", "list comprehension"),
        ("getattr(q1, '__class__')", "'getattr' is not a known function"),
        ("__import__('os')", "'__import__' is not a known function"),
        ("(x := 1)", "assignment expression"),
        ("{1: 2}", "dict"),
        ("f'{m1}'", "f-string"),
    ],
)
def test_malicious_text_is_rejected_without_executing(
    text: str, token: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[str] = []

    def record(command: str) -> int:
        calls.append(command)
        return 0

    monkeypatch.setattr(os, "system", record)
    with pytest.raises(SpecError) as info:
        parse_expression(text, n=2, parameters=["m1"], where=W)
    assert token in str(info.value)
    assert calls == []


def test_long_sums_parse_and_deep_nesting_is_an_error() -> None:
    terms = [f"{k}*q1[{k % 3}]**{k}" for k in range(1, 1001)]
    parsed = parse_expression(" + ".join(terms), n=1, parameters=[], where=W)
    expected = sp.Add(*[k * q_symbol(1, k % 3) ** k for k in range(1, 1001)])
    assert sp.expand(parsed - expected) == 0
    with pytest.raises(SpecError, match=r"\[potential\] V: .*(nested|recursion)"):
        parse_expression("-" * 5000 + "1", n=1, parameters=[], where=W)
    with pytest.raises(SpecError, match="too many nested parentheses"):
        parse_expression("(" * 300 + "1" + ")" * 300, n=1, parameters=[], where=W)


def test_parser_rejects_reserved_parameter_names() -> None:
    with pytest.raises(SpecError, match="parameter name 'pi' is reserved"):
        parse_expression("pi", n=1, parameters=["pi"], where=W)


def test_parser_without_vectors_rejects_positions() -> None:
    where = "spec.toml: [inertia] M[1][1]"
    with pytest.raises(SpecError, match=r"M\[1\]\[1\]: 'q1' is not allowed here"):
        parse_expression("m1*q1[0]", n=2, parameters=["m1"], where=where, allow_vectors=False)
    with pytest.raises(SpecError, match="function 'dot' is not allowed here"):
        parse_expression("dot(e1, e1)", n=2, parameters=[], where=where, allow_vectors=False)


# ---------------------------------------------------------------- spec file errors
def test_missing_file_and_toml_syntax_error(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="nowhere.toml: no such spec file"):
        load_spec(tmp_path / "nowhere.toml")
    spec_error(tmp_path, edit("bodies = 2", "bodies = = 2"), "TOML syntax error", "line 2")


@pytest.mark.parametrize(
    ("old", "new", "fragments"),
    [
        ("bodies = 2", "bodies = 2\ncolour = 1", ["top level: unknown key 'colour'"]),
        ('method = "vi"', 'method = "vi"\nsteps = 3', ["[run]: unknown key 'steps'"]),
        ("[inertia]", "[inertia]\nK = 1", ["[inertia]: unknown key 'K'", "M, diagonal"]),
        ("[potential]", "[potential]\nW = 1", ["[potential]: unknown key 'W'"]),
        ('name = "dp"\n', "", ["missing required key 'name'"]),
        ('V = "', 'U = "', ["[potential]: unknown key 'U'"]),
        ('name = "dp"', 'name = "double pendulum"', ["key 'name'", "not a C identifier"]),
        ('name = "dp"', 'name = "int"', ["key 'name'", "'int' is a reserved word"]),
        ("bodies = 2", "bodies = 0", ["key 'bodies'", "positive integer, got 0"]),
        ("m1 = 1.0", 'm1 = "heavy"', ["[parameters] m1: expected a number, got 'heavy'"]),
        ("m1 = 1.0", "m1 = true", ["[parameters] m1: expected a number, got True"]),
        ("g = 9.81", "g = 9.81\nq1 = 2.0", ["[parameters] q1", "reserved name"]),
        ("g = 9.81", "g = 9.81\npi = 3.0", ["[parameters] pi", "reserved name"]),
        ("g = 9.81", "g = 9.81\nsin = 3.0", ["[parameters] sin", "reserved name"]),
        ("g = 9.81", "g = 9.81\ne1 = 3.0", ["[parameters] e1", "reserved name"]),
        ("g = 9.81", "g = 9.81\nlambda = 3.0", ["[parameters] lambda", "reserved word"]),
        ("h = 0.01", "h = -0.01", ["[run] h: expected a positive number, got -0.01"]),
        ('method = "vi"', 'method = "euler"', ["[run] method: unknown method 'euler'"]),
        ("[run]", "run = 3\n[other]", ["top level: unknown key 'other'"]),
    ],
)
def test_spec_errors_name_key_and_item(
    tmp_path: Path, old: str, new: str, fragments: list[str]
) -> None:
    spec_error(tmp_path, edit(old, new), *fragments)


@pytest.mark.parametrize("method", ["rattle", "vi4"])
def test_run_method_may_be_any_method_of_the_table(method: str) -> None:
    """[run] method is checked against s2gen.methods.NAMES, the one table of methods."""
    s = load_spec_text(edit('method = "vi"', f'method = "{method}"'), origin="spec.toml")
    assert s.run == RunSettings(h=0.01, T=100.0, method=method)


def test_unknown_run_method_lists_the_methods_of_the_table(tmp_path: Path) -> None:
    message = spec_error(tmp_path, edit('method = "vi"', 'method = "euler"'), "unknown method")
    assert f"(one of {', '.join(NAMES)})" in message
    assert all(name in message for name in ("vi", "vi4", "rattle", "rk45", "rk2-proj"))


def test_run_must_be_a_table(tmp_path: Path) -> None:
    text = edit('[run]\nh = 0.01\nT = 100\nmethod = "vi"\n', "").replace(
        'name = "dp"', 'name = "dp"\nrun = 3'
    )
    spec_error(tmp_path, text, "'run' must be a table [run], got 3")


def test_potential_errors(tmp_path: Path) -> None:
    v = 'V = "-(m1+m2)*g*l1*dot(e3, q1) - m2*g*l2*dot(e3, q2)"'
    spec_error(
        tmp_path, edit(v, 'V = "m1*g*dot(e3, q1) + k*q2[0]"'), "[potential] V", "'k'", "column 20"
    )
    spec_error(tmp_path, edit(v, 'V = "g*q1"'), "[potential] V", "is a vector")
    spec_error(tmp_path, edit(v, 'V = "g*q3[2]"'), "[potential] V", "no body 'q3'")
    spec_error(tmp_path, edit(v, 'V = "q1.__class__"'), "[potential] V", "q1.__class__")


M_LINE = 'M = [["(m1+m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]]'


def test_multi_line_potential(tmp_path: Path) -> None:
    v = 'V = "-(m1+m2)*g*l1*dot(e3, q1) - m2*g*l2*dot(e3, q2)"'
    multi = 'V = """\n  -(m1+m2)*g*l1*dot(e3, q1)\n  - m2*g*l2*dot(e3, q2)\n"""'
    s = load_spec(write(tmp_path, edit(v, multi)))
    assert sp.simplify(s.potential - expected_potential()) == 0
    bad = 'V = """\n  -(m1+m2)*g*l1*dot(e3, q1)\n  - m2*g*l2*dot(e3, foo)\n"""'
    spec_error(tmp_path, edit(v, bad), "[potential] V", "unknown name 'foo'", "line 2, column 21")


# ---------------------------------------------------------------- inertia
def test_diagonal_and_full_inertia_agree(tmp_path: Path) -> None:
    diagonal = load_spec(write(tmp_path, edit(M_LINE, 'diagonal = ["m1*l1**2", 2]')))
    full = load_spec(write(tmp_path, edit(M_LINE, 'M = [["m1*l1**2", 0], [0, 2]]')))
    assert diagonal.inertia == sp.ImmutableMatrix([[m1 * l1**2, 0], [0, 2]])
    assert diagonal.is_diagonal and full.is_diagonal
    assert same(diagonal, full)


@pytest.mark.parametrize(
    ("new", "fragments"),
    [
        ('M = [["m1", 0]]', ["[inertia] M: expected 2 rows, got 1"]),
        ('M = [["m1", 0], ["m2"]]', ["[inertia] M[2]: expected 2 entries, got 1"]),
        ('M = [["m1", "q1[0]"], [0, 1]]', ["[inertia] M[1][2]", "'q1' is not allowed here"]),
        ('M = [["m1", "k"], ["k", 1]]', ["[inertia] M[1][2]", "unknown name 'k'"]),
        ('M = [["m1", true], [0, 1]]', ["[inertia] M[1][2]", "got True"]),
        ('M = [["m1", 1], [0, "m2"]]', ["M is not symmetric", "M[1][2] = 1", "M[2][1] = 0"]),
        ('M = [["m1", 2], [2, "m2"]]', ["not positive definite", "smallest eigenvalue -1"]),
        ('M = [["sqrt(-m1)", 0], [0, 1]]', ["[inertia] M is not real"]),
        ('diagonal = ["m1"]', ["[inertia] diagonal: expected 2 entries"]),
        ('diagonal = ["m1", "-m2"]', ["not positive definite", "smallest eigenvalue -1"]),
        (M_LINE + '\ndiagonal = ["m1", "m2"]', ["[inertia]: give exactly one", "both"]),
        ("", ["[inertia]: give exactly one", "neither"]),
    ],
)
def test_inertia_errors(tmp_path: Path, new: str, fragments: list[str]) -> None:
    spec_error(tmp_path, edit(M_LINE, new), *fragments)


# ---------------------------------------------------------------- initial state
Q_LINE = 'q = [["sqrt(3)/2", 0, "1/2"], [0, 0, 1]]'
W_LINE = 'omega = [["-sqrt(3)/4", 0, "3/4"], [0, 1, 0]]'


def test_rounded_initial_values_are_normalized_with_a_warning(tmp_path: Path) -> None:
    text = edit(Q_LINE, "q = [[0.8660, 0.0, 0.5], [0.0, 0.0, 1.0]]")
    text = edit(W_LINE, "omega = [[-0.4330, 0.0, 0.75], [0.0, 1.0, 0.0]]", text)
    with pytest.warns(SpecWarning) as record:
        s = load_spec(write(tmp_path, text))
    message = str(record[0].message)
    # |(0.8660, 0, 0.5)| = 0.99997799..., so the correction is -2.2e-05.
    assert "[initial]" in message and "q1 normalized (length was 1-2.2e-05)" in message
    assert "q2" not in message.split(";")[0]
    np.testing.assert_allclose(np.linalg.norm(s.q0, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.einsum("ij,ij->i", s.q0, s.omega0), 0.0, atol=1e-15)


@pytest.mark.parametrize(
    ("old", "new", "fragments"),
    [
        (Q_LINE, "q = [[0.87, 0, 0.5], [0, 0, 1]]", ["[initial] q1: length", "not a unit vector"]),
        (Q_LINE, "q = [[0, 0, 1]]", ["[initial] q: expected 2 vectors (one per body), got 1"]),
        (Q_LINE, "q = [[0, 0, 1], [0, 1]]", ["[initial] q[2]: expected 3 components, got 2"]),
        (Q_LINE, 'q = [[0, 0, 1], [0, "q1[0]", 1]]', ["[initial] q[2][2]", "'q1' is not"]),
        (Q_LINE, 'q = [[0, 0, 1], [0, "x", 1]]', ["[initial] q[2][2]", "unknown name 'x'"]),
        (
            Q_LINE,
            'q = [[0, 0, 1], [0, "sqrt(-1)", 1]]',
            ["[initial] q[2][2]", "is not real", "column 1"],
        ),
        (Q_LINE, 'q = [[0, 0, 1], [0, "true", 1]]', ["[initial] q[2][2]", "unknown name 'true'"]),
        (W_LINE, "", ["[initial]: give both 'q' and 'omega'"]),
        (W_LINE, "omega = 3", ["[initial] omega: expected a list of 2 vectors"]),
    ],
)
def test_initial_errors(tmp_path: Path, old: str, new: str, fragments: list[str]) -> None:
    spec_error(tmp_path, edit(old, new), *fragments)


def test_initial_values_may_use_parameters(tmp_path: Path) -> None:
    text = edit("g = 9.81", "g = 9.81\nc = 0.5")
    s = load_spec(
        write(tmp_path, edit(Q_LINE, 'q = [["sqrt(1 - c**2)", 0, "c"], [0, 0, 1]]', text))
    )
    np.testing.assert_allclose(s.q0[0], [np.sqrt(0.75), 0, 0.5], atol=1e-15)
