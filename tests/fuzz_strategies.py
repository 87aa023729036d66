"""Hypothesis strategies for fuzzing the spec's front door (used by tests/test_fuzz.py).

Three families of inputs:
- `expression_text`: text shaped like the expression language, valid or not: numbers of every
  kind (huge, tiny, hex, complex, underscores), names known and unknown, vectors and their
  subscripts, good and bad operators, calls of any arity, parentheses, comments, non-ASCII
  characters and attempts to reach Python (`__import__`, attribute access, lambda);
- `valid_expression`: well-typed scalar expressions in q1..q3, e1..e3 and the parameters
  m, k, g (what the parser should accept, unless a number goes out of range);
- `spec_values` / `toml_text`: whole specs as Python values (for `define_system`) and as TOML
  text mutated character by character.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import strategies as st

PARAMETERS = ("m", "k", "g")

_NUMBERS = st.one_of(
    st.integers(-(10**6), 10**6).map(str),
    st.integers(0, 10**40).map(str),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.sampled_from(
        [
            "0",
            "0.0",
            "1e999",
            "1e-400",
            "1e308",
            "2**64",
            "10**20",
            "1_000",
            "0x10",
            "0b11",
            "1j",
            "True",
            "None",
            "'s'",
            "...",
            "9" * 420,
            "1e-320",
            "0.5",
            "3",
        ]
    ),
)
_NAMES = st.sampled_from(
    [
        "m",
        "k",
        "g",
        "pi",
        "e1",
        "e2",
        "e3",
        "q1",
        "q2",
        "q3",
        "q0",
        "q4",
        "q",
        "qi",
        "qj",
        "x",
        "x0",
        "E",
        "I",
        "nan",
        "inf",
        "sqrt",
        "os",
        "__import__",
        "__builtins__",
        "self",
    ]
)
_SUBSCRIPTS = st.builds(
    "{}[{}]".format,
    st.sampled_from(["q1", "q2", "q3", "e1", "m", "(q1 - q2)", "cross(q1, q2)"]),
    st.sampled_from(["0", "1", "2", "3", "-1", "0:2", "m", "1.0", "True"]),
)
_ODD = st.sampled_from(
    [
        "__import__('os').system('touch /tmp/s2gen-fuzz-pwned')",
        "open('/tmp/s2gen-fuzz-pwned', 'w')",
        "q1.__class__",
        "(lambda: 1)()",
        "[x for x in q1]",
        "{1: 2}",
        "f'{m}'",
        "(x := 1)",
        "m if m else k",
        "*q1",
        "m # comment",
        "ｍ",
        "q₁[0]",
        "\u00a0m",
        "m\\\n + k",
        "\x00",
        "`m`",
        "$m",
        "m;k",
        "",
    ]
)
_OPERATORS = st.sampled_from(
    ["+", "-", "*", "/", "**", "+", "-", "*", "/", "**", "%", "//", "^", "@", "<", "and", ","]
)
_FUNCTIONS = st.sampled_from(
    ["sqrt", "exp", "log", "sin", "cos", "tan", "Abs", "dot", "cross", "norm", "min", "getattr"]
)


def _extend(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        st.builds("{} {} {}".format, children, _OPERATORS, children),
        st.builds("({})".format, children),
        st.builds("-{}".format, children),
        st.builds(
            lambda f, args: f"{f}({', '.join(args)})", _FUNCTIONS, st.lists(children, max_size=3)
        ),
        st.builds("({})[{}]".format, children, st.sampled_from(["0", "1", "2", "3"])),
        st.builds("{}\n  {}".format, children, children),
    )


_GRAMMAR = st.recursive(st.one_of(_NUMBERS, _NAMES, _SUBSCRIPTS, _ODD), _extend, max_leaves=10)


@st.composite
def _mutated(draw: st.DrawFn, base: st.SearchStrategy[str]) -> str:
    text = draw(base)
    for _ in range(draw(st.integers(0, 2))):
        at = draw(st.integers(0, len(text)))
        junk = draw(st.text(max_size=3))
        text = text[:at] + junk + text[at + draw(st.integers(0, 2)) :]
    return text


#: Text for the expression parser: grammar-shaped (possibly mutated) or arbitrary.
expression_text = st.one_of(_GRAMMAR, _mutated(_GRAMMAR), st.text(max_size=60))

# ---------------------------------------------------------------- well-typed expressions
_SCALAR_LEAVES = st.one_of(
    st.sampled_from([*PARAMETERS, "pi", "2", "3", "0.5", "1/3", "2.5", "7"]),
    st.builds("q{}[{}]".format, st.integers(1, 3), st.integers(0, 2)),
)
_VECTOR_LEAVES = st.sampled_from(["q1", "q2", "q3", "e1", "e2", "e3"])


def _scalar(depth: int) -> st.SearchStrategy[str]:
    if depth == 0:
        return _SCALAR_LEAVES
    sub, vec = _scalar(depth - 1), _vector(depth - 1)
    return st.one_of(
        _SCALAR_LEAVES,
        st.builds("({} {} {})".format, sub, st.sampled_from(["+", "-", "*", "/"]), sub),
        st.builds("({})**{}".format, sub, st.sampled_from(["2", "3", "-1", "0.5", "(1/3)", "-2"])),
        st.builds(
            "{}({})".format,
            st.sampled_from(["sqrt", "exp", "log", "sin", "cos", "tan", "Abs"]),
            sub,
        ),
        st.builds("dot({}, {})".format, vec, vec),
        st.builds("norm({})".format, vec),
        st.builds("({})[{}]".format, vec, st.integers(0, 2)),
    )


def _vector(depth: int) -> st.SearchStrategy[str]:
    if depth == 0:
        return _VECTOR_LEAVES
    sub, scalar = _vector(depth - 1), _scalar(depth - 1)
    return st.one_of(
        _VECTOR_LEAVES,
        st.builds("({} {} {})".format, sub, st.sampled_from(["+", "-"]), sub),
        st.builds("{}*{}".format, scalar, sub),
        st.builds("cross({}, {})".format, sub, sub),
    )


#: Well-typed scalar expressions in q1..q3, e1..e3 and the parameters m, k, g.
valid_expression = _scalar(3)
#: The same, nested at most twice (cheaper to derive and compile: the default run's budget).
small_expression = _scalar(2)

# ---------------------------------------------------------------- whole specs
_ANY_VALUE = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**20), 10**20),
    st.floats(),
    st.text(max_size=12),
    expression_text,
    st.lists(st.one_of(st.integers(-3, 3), st.floats(), st.text(max_size=4)), max_size=4),
    st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
)
_NAME_VALUES = st.one_of(
    st.sampled_from(["sys", "abc\n", "_math", "int", "3d", "a" * 100, "", "ok_name", "q1"]),
    st.text(max_size=10),
    _ANY_VALUE,
)
_PARAMETER_NAMES = st.one_of(
    st.sampled_from([*PARAMETERS, "pi", "q1", "x0", "lambda", "e1", "q", "I", "a b", ""]),
    st.text(max_size=6),
)


def _vectors(n: int) -> st.SearchStrategy[Any]:
    component = st.one_of(
        st.floats(-2, 2), st.integers(-1, 1), st.sampled_from(["sqrt(3)/2", "1/2", "m", "nan"])
    )
    return st.one_of(
        st.lists(st.lists(component, min_size=3, max_size=3), min_size=n, max_size=n),
        st.lists(st.lists(component, max_size=4), max_size=n + 1),
        _ANY_VALUE,
    )


def _mostly(
    valid: st.SearchStrategy[Any], invalid: st.SearchStrategy[Any]
) -> st.SearchStrategy[Any]:
    """`valid` three times in four (so that later stages see inputs too), else `invalid`."""
    return st.sampled_from([0, 1, 2, 3]).flatmap(lambda k: invalid if k == 3 else valid)


@st.composite
def spec_values(draw: st.DrawFn) -> dict[str, Any]:
    """Keyword arguments for `define_system`: each field plausible three times in four."""
    n = draw(_mostly(st.integers(1, 3), st.sampled_from([0, -1, 10**9, 2.5, True, "2"])))
    size = n if isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= 3 else 2
    params = draw(
        _mostly(
            st.fixed_dictionaries({p: st.floats(0.1, 10) for p in PARAMETERS}),
            st.dictionaries(
                _PARAMETER_NAMES,
                st.one_of(st.floats(0.1, 10), st.floats(), st.text(max_size=3)),
                max_size=4,
            ),
        )
    )
    diagonal = draw(
        _mostly(
            st.lists(st.sampled_from(["m", "k", "1", "2.0", "m*k"]), min_size=size, max_size=size),
            st.one_of(
                st.lists(
                    st.sampled_from(["m", "-1", "m/0", "q1[0]", "sqrt(-1)", "0", "1e400"]),
                    min_size=size,
                    max_size=size,
                ),
                _ANY_VALUE,
            ),
        )
    )
    values: dict[str, Any] = {
        "name": draw(_mostly(st.just("fz"), _NAME_VALUES)),
        "bodies": n,
        "parameters": params,
        "potential": draw(_mostly(valid_expression, st.one_of(expression_text, _ANY_VALUE))),
        "diagonal": diagonal,
    }
    if draw(st.booleans()):
        unit = st.sampled_from([[0, 0, 1], [1, 0, 0], ["sqrt(3)/2", 0, "1/2"]])
        values["initial_q"] = draw(
            _mostly(st.lists(unit, min_size=size, max_size=size), _vectors(size))
        )
        values["initial_omega"] = draw(_mostly(st.just([[0.0, 0.0, 0.0]] * size), _vectors(size)))
    if draw(st.booleans()):
        values["run"] = draw(
            _mostly(
                st.fixed_dictionaries(
                    {"h": st.floats(1e-4, 0.1), "T": st.floats(0.1, 10)},
                    optional={"method": st.sampled_from(["vi", "rk45", "rk4"])},
                ),
                st.one_of(
                    st.dictionaries(
                        st.sampled_from(["h", "T", "method", "rtol", "atol", "x"]),
                        st.one_of(st.floats(), st.sampled_from(["vi", "rk45", "nope"])),
                        max_size=3,
                    ),
                    _ANY_VALUE,
                ),
            )
        )
    if draw(st.booleans()):
        values["pair_terms"] = draw(_mostly(_good_pair_terms(size), _bad_pair_terms()))
    return values


def _good_pair_terms(n: int) -> st.SearchStrategy[Any]:
    pairs = st.sampled_from(["chain"] + ([[[1, 2]]] if n >= 2 else []))
    return st.lists(
        st.fixed_dictionaries(
            {
                "V": st.sampled_from(
                    ["c*dot(qi, qj)", "c*norm(qi - qj)**2", "c/(3 - dot(qi, qj))"]
                ),
                "pairs": pairs,
                "data": st.just({"c": [1.5] * max(n - 1, 1)}),
            }
        ),
        max_size=1,
    )


def _bad_pair_terms() -> st.SearchStrategy[Any]:
    return st.one_of(
        st.lists(
            st.fixed_dictionaries(
                {"V": st.one_of(st.just("c*dot(qi, qj)"), expression_text)},
                optional={
                    "pairs": st.one_of(
                        st.sampled_from(["all", "chain", [[1, 2]], [[1, 1]], [[0, 2]]]),
                        _ANY_VALUE,
                    ),
                    "data": st.one_of(
                        st.dictionaries(
                            st.sampled_from(["c", "i", "C", "x0", "pi", "qi", "d"]),
                            st.one_of(
                                st.lists(st.floats(), max_size=3),
                                st.lists(st.lists(st.floats(), max_size=3), max_size=2),
                            ),
                            max_size=2,
                        ),
                        _ANY_VALUE,
                    ),
                    "cutoff": st.one_of(st.floats(), _ANY_VALUE),
                },
            ),
            max_size=2,
        ),
        _ANY_VALUE,
    )


BASE_TOML = """\
name = "fuzz"
bodies = 2
[parameters]
m = 1.0
k = 2.0
[inertia]
diagonal = ["m", "m"]
[potential]
V = "-m*q1[2] + k*dot(q1, q2)"
[[potential.pair]]
V = "c*dot(qi, qj)"
pairs = [[1, 2]]
[potential.pair.data]
c = [1.5]
[initial]
q = [[0, 0, 1], [1, 0, 0]]
omega = [[0, 1, 0], [0, 0, 1]]
[run]
h = 0.01
T = 1.0
method = "vi"
"""

_TOML_PIECES = st.sampled_from(
    [
        "=",
        '"',
        "[",
        "]",
        "\n",
        "#",
        ",",
        "0",
        "-",
        "1e999",
        "nan",
        "inf",
        "q1",
        "[[potential.body]]\n",
        'V = "q[2]"\n',
        "bodies = 5\n",
        "x = 1\n",
        "\\",
        "'",
        "{",
        "}",
        "ｍ",
        "\x00",
        "true",
    ]
)


@st.composite
def toml_text(draw: st.DrawFn) -> str:
    """The base spec with a few pieces inserted, deleted or replaced."""
    text = BASE_TOML
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        cut = draw(st.integers(0, 3))
        piece = draw(st.one_of(_TOML_PIECES, st.text(max_size=3)))
        text = text[:at] + piece + text[at + cut :]
    return text


def random_point(n: int, seed: int) -> np.ndarray:
    """n unit vectors away from the axes (so that Abs and sqrt of components are smooth)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(0.2, 1.0, size=(n, 3)) * rng.choice([-1.0, 1.0], size=(n, 3))
    return q / np.linalg.norm(q, axis=1)[:, None]


def finite_close(a: float, b: float, rtol: float) -> bool:
    """Two finite numbers equal to within rtol of the larger magnitude (or both tiny)."""
    scale = max(abs(a), abs(b))
    return abs(a - b) <= rtol * scale or scale < 1e-300 or math.isclose(a, b, rel_tol=rtol)
