"""Tests of structured potentials at the front doors: [[potential.body]] / [[potential.pair]]
tables, the `body_terms` / `pair_terms` API, local names in the parser, and their errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sympy as sp

from s2gen.spec import define_system, load_spec, load_spec_text, parse_expression
from s2gen.symbols import local_vector, q_symbol, q_vector
from s2gen.system import SpecError, System, Term, TermData
from s2gen.terms import TermKind, spellings

SPECS = Path(__file__).parent / "specs"
PARAMS = {"m": 0.1, "l": 0.1, "g": 9.81}
m, l, g, k, c = sp.symbols("m l g k c", real=True)
q, qi, qj, r = (sp.Matrix(local_vector(name)) for name in ("q", "qi", "qj", "r"))

BASE = """\
name = "ring"
bodies = 4
[parameters]
m = 0.1
l = 0.1
g = 9.81
[inertia]
diagonal = ["m*l**2", "m*l**2", "m*l**2", "m*l**2"]
[potential]

[[potential.body]]
V = "-m*g*l*q[2]"
bodies = "all"

[[potential.pair]]
V = "k/2*(norm(r + l/2*qj - l/2*qi) - norm(r))**2"
pairs = [[1, 2], [2, 3], [3, 4], [4, 1]]
[potential.pair.data]
k = [10, 20, 30, 40]
r = [[0.1, 0, 0], [0, -0.1, 0], [-0.1, 0, 0], [0, 0.1, 0]]

[[potential.pair]]
V = "c*dot(qi, qj)"
pairs = "chain"
[potential.pair.data]
c = [1, 2, 3]
"""
SPRING = "k/2*(norm(r + l/2*qj - l/2*qi) - norm(r))**2"
SPRING_DATA = {
    "k": [10, 20, 30, 40],
    "r": [[0.1, 0, 0], [0, -0.1, 0], [-0.1, 0, 0], [0, 0.1, 0]],
}
PAIRS = [[1, 2], [2, 3], [3, 4], [4, 1]]


def edit(old: str, new: str, text: str = BASE) -> str:
    """BASE with one exact replacement (fails loudly if `old` is not there exactly once)."""
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
    assert message.startswith(str(tmp_path / "spec.toml") + ": "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    return message


def api(**overrides: Any) -> System:
    """The BASE system through the Python API, with keyword overrides."""
    kwargs: dict[str, Any] = {
        "name": "ring",
        "bodies": 4,
        "parameters": PARAMS,
        "diagonal": ["m*l**2"] * 4,
        "body_terms": [{"V": "-m*g*l*q[2]", "bodies": "all"}],
        "pair_terms": [
            {"V": SPRING, "pairs": PAIRS, "data": SPRING_DATA},
            {"V": "c*dot(qi, qj)", "pairs": "chain", "data": {"c": [1, 2, 3]}},
        ],
    }
    kwargs.update(overrides)
    return define_system(**kwargs)


def api_error(*fragments: str, **overrides: Any) -> str:
    with pytest.raises(SpecError) as info:
        api(**overrides)
    message = str(info.value)
    assert message.startswith("<python api>: "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    return message


def numeric(expr: sp.Expr, system: System) -> sp.Expr:
    """`expr` with the system's parameter values substituted."""
    return expr.xreplace(dict(zip(system.parameter_symbols, system.parameter_values)))


def random_points(n: int, count: int, seed: int = 7) -> np.ndarray:
    """`count` random points of (S^2)^n, each flattened body-major (the q-symbol order)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(count, n, 3))
    return (x / np.linalg.norm(x, axis=2, keepdims=True)).reshape(count, 3 * n)


def assert_same_function(a: sp.Expr, b: sp.Expr, n: int) -> None:
    """Equal values and gradients of two expressions in q1..qn at random points, to 1e-12."""
    qs = [q_symbol(i, cc) for i in range(1, n + 1) for cc in range(3)]
    assert (a.free_symbols | b.free_symbols) <= set(qs)
    exprs = [a - b] + [sp.diff(a - b, s) for s in qs]
    f = sp.lambdify(qs, exprs, "numpy")
    scale = 1.0 + max(abs(float(a.subs(dict(zip(qs, x))))) for x in random_points(n, 3))
    for x in random_points(n, 20):
        np.testing.assert_allclose(f(*x), 0.0, rtol=0, atol=1e-12 * scale)


# ---------------------------------------------------------------- the parser's local names
BODY = {"q": 3}
PAIR = {"qi": 3, "qj": 3}


def local_parse(text: str, local: dict[str, int], parameters: tuple[str, ...] = ("m", "l")) -> Any:
    return parse_expression(
        text,
        n=4,
        parameters=list(parameters),
        where="spec.toml: [[potential.pair]] #2 V",
        local=local,
    )


@pytest.mark.parametrize(
    ("text", "local", "expected"),
    [
        ("q[0] + 2*dot(e3, q)", BODY, q[0] + 2 * q[2]),
        ("-m*l*norm(q)", BODY, -m * l * sp.sqrt(q.dot(q))),
        ("dot(qi, qj)", PAIR, qi.dot(qj)),
        ("cross(qi, qj)[2] + qj[1]*pi", PAIR, qi.cross(qj)[2] + qj[1] * sp.pi),
        ("k*dot(r, qi)", {**PAIR, "k": 1, "r": 3}, k * r.dot(qi)),
        (
            "norm(r + l/2*qj) - norm(r)",
            {**PAIR, "r": 3},
            sp.sqrt((r + l / 2 * qj).dot(r + l / 2 * qj)) - sp.sqrt(r.dot(r)),
        ),
        ("r[1]*sin(k) + exp(m)", {**BODY, "k": 1, "r": 3}, r[1] * sp.sin(k) + sp.exp(m)),
        ("dot(cross(r, q), e1)", {**BODY, "r": 3}, r.cross(q)[0]),
    ],
)
def test_local_names_parse_to_local_symbols(
    text: str, local: dict[str, int], expected: Any
) -> None:
    assert sp.simplify(local_parse(text, local) - expected) == 0


@pytest.mark.parametrize(
    ("text", "local", "fragments"),
    [
        ("k*dot(q1, qi)", {**PAIR, "k": 1}, ["global position 'q1'", "here qi and qj", "column 7"]),
        ("q2[0]", BODY, ["global position 'q2'", "here q)", "column 1"]),
        ("q9[0]", BODY, ["global position 'q9'"]),
        ("dot(qi, e3)", BODY, ["unknown name 'qi' (this term's own vectors are q) at column 5"]),
        ("q[0]", PAIR, ["unknown name 'q' (this term's own vectors are qi and qj)"]),
        ("m + foo", PAIR, ["unknown name 'foo'", "column 5"]),
        ("m*r", {**PAIR, "r": 3}, ["'m*r' is a vector"]),
        ("k[0]", {**PAIR, "k": 1}, ["cannot index the scalar 'k'"]),
        ("r**2", {**PAIR, "r": 3}, ["'**' needs scalars", "column 2"]),
        ("m + qi", PAIR, ["cannot combine a scalar and a vector", "column 3"]),
    ],
)
def test_local_parse_errors(text: str, local: dict[str, int], fragments: list[str]) -> None:
    with pytest.raises(SpecError) as info:
        local_parse(text, local)
    message = str(info.value)
    assert message.startswith("spec.toml: [[potential.pair]] #2 V: "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_term_roles_are_unknown_in_the_general_potential() -> None:
    with pytest.raises(SpecError, match=r"\[potential\] V: unknown name 'qi' \(q, qi and qj exist"):
        parse_expression("dot(qi, e3)", n=2, parameters=[], where="x: [potential] V")
    with pytest.raises(SpecError, match="'q' is not allowed here"):
        parse_expression("q", n=0, parameters=[], where="x", allow_vectors=False)


def test_local_names_may_not_clash_with_parameters_or_reserved_names() -> None:
    with pytest.raises(SpecError, match="local name 'm' clashes with a parameter name 'm'"):
        local_parse("m", {"m": 1})
    with pytest.raises(SpecError, match="local name 'e1' clashes with reserved"):
        local_parse("1", {"e1": 3})
    with pytest.raises(SpecError, match="local name 'r' has width 2"):
        local_parse("1", {"r": 2})


# ---------------------------------------------------------------- springs4 two ways
def test_springs4_terms_matches_the_explicit_springs4() -> None:
    explicit = load_spec(SPECS / "springs4.toml")
    terms = load_spec(SPECS / "springs4_terms.toml")
    assert terms.potential == 0
    assert [(t.kind, t.select, t.label) for t in terms.terms] == [
        ("body", "all", "[[potential.body]] #1"),
        ("pair", "list", "[[potential.pair]] #1"),
    ]
    assert terms.terms[1].member_list(4) == [(0, 1), (1, 2), (2, 3), (3, 0)]
    assert terms.inertia == explicit.inertia
    np.testing.assert_array_equal(terms.q0, explicit.q0)
    np.testing.assert_array_equal(terms.omega0, explicit.omega0)
    assert terms.run == explicit.run
    a = numeric(explicit.potential, explicit)
    b = numeric(terms.full_potential(), terms)
    assert sp.simplify(a - b) == 0
    assert_same_function(a, b, 4)


# ---------------------------------------------------------------- TOML vs API
def same(a: System, b: System) -> bool:
    return dataclasses.replace(a, origin="") == dataclasses.replace(b, origin="")


def test_toml_and_api_give_equal_systems(tmp_path: Path) -> None:
    from_toml = load_spec(write(tmp_path, BASE))
    from_api = api()
    assert same(from_toml, from_api)
    assert from_toml.spec_hash() == from_api.spec_hash()
    assert [t.label for t in from_api.terms] == [
        "[[potential.body]] #1",
        "[[potential.pair]] #1",
        "[[potential.pair]] #2",
    ]
    assert same(from_toml, load_spec_text(BASE, origin="elsewhere"))


def test_api_accepts_sympy_expressions_and_arrays(tmp_path: Path) -> None:
    from_toml = load_spec(write(tmp_path, BASE))
    spring = (
        k
        / 2
        * (
            sp.sqrt((r + l / 2 * qj - l / 2 * qi).dot(r + l / 2 * qj - l / 2 * qi))
            - sp.sqrt(r.dot(r))
        )
        ** 2
    )
    data = {"k": np.array([10.0, 20, 30, 40]), "r": np.array(SPRING_DATA["r"])}
    from_sympy = api(
        body_terms=[{"V": -m * g * l * q[2]}],
        pair_terms=[
            {"V": spring, "pairs": np.array(PAIRS), "data": data},
            {"V": c * qi.dot(qj), "pairs": "chain", "data": {"c": (1.0, 2.0, 3.0)}},
        ],
    )
    assert [t.data for t in from_sympy.terms] == [t.data for t in from_toml.terms]
    assert [t.member_list(4) for t in from_sympy.terms] == [
        t.member_list(4) for t in from_toml.terms
    ]
    for a, b in zip(from_sympy.terms, from_toml.terms):
        assert sp.simplify(a.expr - b.expr) == 0


def test_general_part_and_terms_add_up() -> None:
    s = api(potential="m*q1[0]")
    assert s.potential == m * q_symbol(1, 0)
    assert sp.expand(s.full_potential() - api().full_potential() - s.potential) == 0


def test_data_values_may_be_parameter_expressions(tmp_path: Path) -> None:
    text = edit("r = [[0.1, 0, 0], [0, -0.1, 0]", 'r = [["l", 0, 0], [0, "-l", "0*g"]')
    text = edit("c = [1, 2, 3]", 'c = ["sqrt(4)", "m*20", 3.0]', text)
    s = load_spec(write(tmp_path, text))
    assert s.terms[1].data[1].values[:6] == (0.1, 0.0, 0.0, 0.0, -0.1, 0.0)
    assert s.terms[2].data == (TermData("c", 1, (2.0, 2.0, 3.0)),)


# ---------------------------------------------------------------- selections and expansion
def pair_term(pairs: Any, data: Any = None, v: Any = "dot(qi, qj)") -> dict[str, Any]:
    return {"V": v, "pairs": pairs, **({"data": data} if data is not None else {})}


@pytest.mark.parametrize(
    ("term", "select", "members"),
    [
        (pair_term("chain"), "chain", [(0, 1), (1, 2), (2, 3)]),
        (pair_term("all"), "all", [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]),
        (pair_term([[4, 1], [2, 3]]), "list", [(3, 0), (1, 2)]),
    ],
)
def test_pair_selections_expand_to_the_right_members(
    term: dict, select: str, members: list[tuple[int, int]]
) -> None:
    (t,) = api(body_terms=None, pair_terms=[term]).terms
    assert (t.kind, t.select, t.member_list(4), t.count(4)) == (
        "pair",
        select,
        members,
        len(members),
    )
    expected = sum((q_vector(i + 1).dot(q_vector(j + 1)) for i, j in members), sp.Integer(0))
    assert sp.expand(api(body_terms=None, pair_terms=[term]).full_potential() - expected) == 0


@pytest.mark.parametrize(
    ("term", "select", "members"),
    [
        ({"V": "q[2]", "bodies": "all"}, "all", [(0,), (1,), (2,), (3,)]),
        ({"V": "q[2]"}, "all", [(0,), (1,), (2,), (3,)]),
        ({"V": "q[2]", "bodies": [3, 1]}, "list", [(2,), (0,)]),
    ],
)
def test_body_selections_expand_to_the_right_members(
    term: dict, select: str, members: list[tuple[int]]
) -> None:
    (t,) = api(body_terms=[term], pair_terms=None).terms
    assert (t.kind, t.select, t.member_list(4)) == ("body", select, members)


def test_full_potential_matches_hand_built_sympy(tmp_path: Path) -> None:
    text = """name = "mix"
bodies = 3
[parameters]
m = 2.0
gamma = 0.5
[inertia]
diagonal = ["m", "m", "m"]
[potential]
V = "m*q2[0]"
[[potential.body]]
V = "-a*dot(e3, q) + dot(w, q)"
bodies = [1, 3]
[potential.body.data]
a = [0.5, "m"]
w = [[1, 2, 3], [0, 0, "gamma"]]
[[potential.pair]]
V = "-gamma/norm(qi - qj)"
pairs = "all"
[[potential.pair]]
V = "kc*(dot(qi, qj) - cos(t))**2"
pairs = "chain"
[potential.pair.data]
kc = [3, 4]
t = [0.25, 0.5]
"""
    s = load_spec(write(tmp_path, text))
    m_, gamma = sp.symbols("m gamma", real=True)
    q1, q2, q3 = (q_vector(i) for i in (1, 2, 3))
    e3 = sp.Matrix([0, 0, 1])
    w1, w3 = sp.Matrix([1, 2, 3]), sp.Matrix([0, 0, sp.Rational(1, 2)])
    expected = (
        m_ * q2[0]
        - sp.Rational(1, 2) * e3.dot(q1)
        + w1.dot(q1)
        - 2 * e3.dot(q3)
        + w3.dot(q3)
        - gamma * sum(1 / (a - b).norm() for a, b in ((q1, q2), (q1, q3), (q2, q3)))
        + 3 * (q1.dot(q2) - sp.cos(sp.Rational(1, 4))) ** 2
        + 4 * (q2.dot(q3) - sp.cos(sp.Rational(1, 2))) ** 2
    )
    assert_same_function(numeric(s.full_potential(), s), numeric(expected, s), 3)
    assert [t.member_list(3) for t in s.terms] == [
        [(0,), (2,)],
        [(0, 1), (0, 2), (1, 2)],
        [(0, 1), (1, 2)],
    ]


# ---------------------------------------------------------------- spec file errors
K_LINE = "k = [10, 20, 30, 40]"
R_LINE = "r = [[0.1, 0, 0], [0, -0.1, 0], [-0.1, 0, 0], [0, 0.1, 0]]"
PAIRS_LINE = "pairs = [[1, 2], [2, 3], [3, 4], [4, 1]]"
CHAIN_V = 'V = "c*dot(qi, qj)"'
P1 = "[[potential.pair]] #1"
#: The named pair selections as the message lists them ("all", "chain", ...), in table order.
NAMED_PAIRS = ", ".join(f'"{w}"' for w in spellings(TermKind.PAIR, named=True))
P2 = "[[potential.pair]] #2"
B1 = "[[potential.body]] #1"


@pytest.mark.parametrize(
    ("old", "new", "fragments"),
    [
        # lengths of data
        (
            K_LINE,
            "k = [10, 20, 30]",
            [f"{P1} data.k: expected 4 values (one per listed pair), got 3"],
        ),
        (
            "c = [1, 2, 3]",
            "c = [1, 2, 3, 4]",
            [f"{P2} data.c: expected 3 values (one per pair of the chain), got 4"],
        ),
        (K_LINE, "k = 5", [f"{P1} data.k: expected a list of 4 values", "got 5"]),
        (
            'bodies = "all"',
            'bodies = "all"\n[potential.body.data]\nh = [1, 2]',
            [f"{B1} data.h: expected 4 values (one per body), got 2"],
        ),
        # data names
        (
            K_LINE,
            "m = [10, 20, 30, 40]",
            [f"{P1} data.m: data name 'm' clashes with the parameter 'm'"],
        ),
        (K_LINE, "pi = [10, 20, 30, 40]", [f"{P1} data.pi: data name 'pi' is a reserved name"]),
        (K_LINE, "e1 = [10, 20, 30, 40]", [f"{P1} data.e1", "reserved name"]),
        (K_LINE, "sqrt = [10, 20, 30, 40]", [f"{P1} data.sqrt", "reserved name"]),
        (K_LINE, "q2 = [10, 20, 30, 40]", [f"{P1} data.q2", "reserved name"]),
        (
            K_LINE,
            "qi = [10, 20, 30, 40]",
            [f"{P1} data.qi: data name 'qi' is reserved for a term's own vector"],
        ),
        (K_LINE, "q = [10, 20, 30, 40]", [f"{P1} data.q: data name 'q' is reserved"]),
        (K_LINE, "qj = [10, 20, 30, 40]", [f"{P1} data.qj", "reserved for a term's own vector"]),
        (
            K_LINE,
            '"a b" = [10, 20, 30, 40]',
            [f"{P1} data.'a b': data name 'a b' is not an identifier"],
        ),
        (K_LINE, "for = [10, 20, 30, 40]", [f"{P1} data.for", "reserved word"]),
        (
            K_LINE,
            "k = [10, 20, 30, 40]\nr_1 = [1, 2, 3, 4]",
            [P1, "the datum 'r' uses the symbol r_1, which is also the datum 'r_1'"],
        ),
        (
            K_LINE,
            "qi_0 = [10, 20, 30, 40]",
            [P1, "the datum 'qi_0' uses the symbol qi_0, which is also the term's vector qi"],
        ),
        (
            "g = 9.81",
            "g = 9.81\nr_2 = 1.0",
            [P1, "the datum 'r' uses the symbol r_2, which is also the parameter 'r_2'"],
        ),
        (
            "g = 9.81",
            "g = 9.81\nqj = 1.0",
            [P1, "the parameter 'qj' clashes with the term's own vector qj"],
        ),
        (
            "g = 9.81",
            "g = 9.81\nq_1 = 1.0",
            [B1, "the term's vector q uses the symbol q_1, which is also the parameter 'q_1'"],
        ),
        # per-pair data with "all"
        (
            PAIRS_LINE,
            'pairs = "all"',
            [f'{P1} data.k: per-pair data need an explicit list of pairs or "chain"'],
        ),
        # selections
        (PAIRS_LINE, "pairs = [[1, 2], [2, 5]]", [f"{P1} pairs[2]: body 5 is not one of 1..4"]),
        (
            PAIRS_LINE,
            "pairs = [[0, 1]]",
            [f"{P1} pairs[1]: body 0 is not one of 1..4 (indices are 1-based)"],
        ),
        (
            PAIRS_LINE,
            "pairs = [[1, 2], [3, 3]]",
            [f"{P1} pairs[2]: the pair [3, 3] joins body 3 with itself"],
        ),
        (
            PAIRS_LINE,
            "pairs = [[1, 2, 3]]",
            [f"{P1} pairs[1]: expected a pair [i, j] of body indices 1..4, got [1, 2, 3]"],
        ),
        (PAIRS_LINE, "pairs = [[1, 2.0]]", [f"{P1} pairs[1]: expected a body index 1..4, got 2.0"]),
        (
            PAIRS_LINE,
            'pairs = "spiral"',
            [f"{P1} pairs: expected {NAMED_PAIRS} or a list of pairs", "got 'spiral'"],
        ),
        (PAIRS_LINE, "pairs = []", [f"{P1} pairs: expected", "got []"]),
        (PAIRS_LINE, "", [f"{P1}: missing required key 'pairs'"]),
        (
            'bodies = "all"',
            'bodies = "chain"',
            [f"{B1} bodies: expected \"all\" or a list of body indices 1..4, got 'chain'"],
        ),
        ('bodies = "all"', "bodies = [1, 7]", [f"{B1} bodies[2]: body 7 is not one of 1..4"]),
        (
            'bodies = "all"',
            "bodies = [true]",
            [f"{B1} bodies[1]: expected a body index 1..4, got True"],
        ),
        # keys
        (
            'bodies = "all"',
            'bodies = "all"\nkind = 1',
            [f"{B1}: unknown key 'kind' (allowed: V, bodies, data)"],
        ),
        (
            PAIRS_LINE,
            PAIRS_LINE + '\nbodies = "all"',
            [f"{P1}: unknown key 'bodies' (allowed: V, pairs, data, cutoff)"],
        ),
        ('V = "-m*g*l*q[2]"\n', "", [f"{B1}: missing required key 'V'"]),
        (
            "[potential]\n",
            "[potential]\ntriple = 1\n",
            ["[potential]: unknown key 'triple' (allowed: V, body, pair)"],
        ),
        # data entries
        (
            K_LINE,
            "k = [10, true, 30, 40]",
            [f"{P1} data.k[2]: expected a number or a 3-vector, got True"],
        ),
        (
            K_LINE,
            "k = [10, {a = 1}, 30, 40]",
            [f"{P1} data.k[2]: expected a number or a 3-vector, got {{'a': 1}}"],
        ),
        (
            R_LINE,
            "r = [[0.1, 0], [0, -0.1, 0], [-0.1, 0, 0], [0, 0.1, 0]]",
            [f"{P1} data.r[1]: expected a number or a 3-vector, got a list of 2"],
        ),
        (
            K_LINE,
            "k = [10, [1, 0, 0], 30, 40]",
            [
                f"{P1} data.k[2]: a 3-vector, but entry 1 is a number",
                "all numbers or all 3-vectors",
            ],
        ),
        (
            R_LINE,
            "r = [[0.1, 0, 0], 2, [-0.1, 0, 0], [0, 0.1, 0]]",
            [f"{P1} data.r[2]: a number, but entry 1 is a 3-vector"],
        ),
        (K_LINE, 'k = [10, "x", 30, 40]', [f"{P1} data.k[2]: unknown name 'x' at column 1"]),
        (
            R_LINE,
            'r = [[0.1, 0, 0], [0, "l*q1[0]", 0], [-0.1, 0, 0], [0, 0.1, 0]]',
            [f"{P1} data.r[2][2]: 'q1' is not allowed here"],
        ),
        (K_LINE, 'k = [10, "1/0", 30, 40]', [f"{P1} data.k[2]: division by zero"]),
        (
            K_LINE,
            'k = [10, "sqrt(-m)", 30, 40]',
            [f"{P1} data.k[2]: 'sqrt(-m)' is not a real number"],
        ),
        (K_LINE, "k = [10, nan, 30, 40]", [f"{P1} data.k[2]: value nan is not finite"]),
        # expressions
        (
            CHAIN_V,
            'V = "c*dot(q1, qj)"',
            [
                f"{P2} V: the global position 'q1' is not allowed in a term expression",
                "here qi and qj",
                "column 7",
            ],
        ),
        (
            'V = "-m*g*l*q[2]"',
            'V = "-m*g*l*q3[2]"',
            [f"{B1} V: the global position 'q3'", "here q)", "column 8"],
        ),
        (
            CHAIN_V,
            'V = "c*dot(q, qj)"',
            [f"{P2} V: unknown name 'q' (this term's own vectors are qi and qj) at column 7"],
        ),
        (CHAIN_V, 'V = "k*dot(qi, qj)"', [f"{P2} V: unknown name 'k' at column 1"]),
        (CHAIN_V, 'V = "c*qi"', [f"{P2} V: the expression 'c*qi' is a vector"]),
        (
            CHAIN_V,
            'V = """c*dot(qi, qj)\n  + dot(r, qi)"""',
            [f"{P2} V: unknown name 'r' at line 2, column 9"],
        ),
        # the general part
        (
            "[potential]\n",
            '[potential]\nV = "q[0]"\n',
            ["[potential] V: unknown name 'q' (q, qi and qj exist only in term"],
        ),
    ],
)
def test_term_errors_name_file_key_and_item(
    tmp_path: Path, old: str, new: str, fragments: list[str]
) -> None:
    spec_error(tmp_path, edit(old, new), *fragments)


def test_potential_needs_v_or_terms(tmp_path: Path) -> None:
    start = BASE.index("[[potential.body]]")
    spec_error(tmp_path, BASE[:start], "[potential]: missing required key 'V' (required unless")
    assert load_spec(write(tmp_path, BASE[:start] + 'V = "q1[2]"\n')).terms == ()


def test_a_single_term_table_is_an_error(tmp_path: Path) -> None:
    text = edit("[[potential.body]]", "[potential.body]")
    spec_error(tmp_path, text, "[[potential.body]]: expected a list of term tables", "got {")


# ---------------------------------------------------------------- Python API errors
def test_api_errors_name_the_term_and_key() -> None:
    api_error("[potential] V: missing", body_terms=None, pair_terms=None)
    api_error("[potential] V: missing", body_terms=[], pair_terms=[])
    api_error("[[potential.pair]]: expected a list of term tables", pair_terms={"V": "1"})
    api_error("[[potential.body]] #2: expected a table", body_terms=[{"V": "q[0]"}, "q[1]"])
    api_error(
        f"{P1} V: the global positions q1_2 are not allowed in a term expression",
        pair_terms=[pair_term("chain", v=q_symbol(1, 2) * qi[0])],
    )
    api_error(
        f"{B1} V: depends on qi_0, which is not one of the term's vectors (q)",
        body_terms=[{"V": qi[0]}],
    )
    api_error(f"{B1} V: the term is a (3, 1) matrix", body_terms=[{"V": q}])
    api_error(f"{B1} V: expected an expression string or a SymPy scalar", body_terms=[{"V": None}])
    api_error(f"{P1} data: expected a table", pair_terms=[pair_term("chain", data=[1, 2, 3])])
    api_error(
        f"{P1} data.7: data name 7 is not an identifier",
        pair_terms=[pair_term("chain", data={7: [1, 2, 3]})],
    )
    api_error(
        f"{P1} pairs[1]: the pair [2, 2] joins body 2 with itself",
        pair_terms=[pair_term(np.array([[2, 2]]))],
    )
    api_error(
        f"{P1} data.r[3]: expected a number or a 3-vector, got a list of 4",
        pair_terms=[pair_term("chain", data={"r": [[0, 0, 0], (1, 2, 3), [0, 0, 0, 0]]})],
    )


def test_api_numbers_and_constant_terms() -> None:
    s = api(body_terms=[{"V": 2.5, "bodies": [2]}], pair_terms=None)
    assert s.terms == (Term("body", sp.Float(2.5), "list", ((1,),), (), "[[potential.body]] #1"),)
    assert s.full_potential() == sp.Float(2.5)
