"""The expression parser's limits and what it refuses (issue 8, items 3, 10 and 11).

Before the fixes: `-m*g*q1[2] # - m*g*q2[2]` silently lost its second term (Python's tokenizer
reads '#' as a comment); `sqrt(3)**(10**8)` took 41 s (SymPy computed 3**(5*10**7): the digit
guard looked only at numeric bases); `sqrt(3)**(10**5)` failed with Python's "Exceeds the limit
(4300 digits) for integer string conversion" and `0.0**2` with "math domain error", neither
naming the key, the token or the column; a full-width 'ｍ' read as the parameter m (identifiers
are NFKC-normalized); `exp(1000)`, `10**400` or `1e200**2` were accepted and became inf (or a
compile warning) in the emitted code.
"""

from __future__ import annotations

import pytest
import sympy as sp
from reliability_helpers import one_line_error

from s2gen.spec import load_spec_text, parse_expression
from s2gen.symbols import q_symbol
from s2gen.system import SpecError

W = "spec.toml: [potential] V"


def parse(text: str) -> sp.Expr:
    return parse_expression(text, n=2, parameters=["m", "g"], where=W)


def error(text: str) -> str:
    return one_line_error(lambda: parse(text), SpecError)


@pytest.mark.parametrize(
    ("text", "at"),
    [
        ("-m*g*q1[2] # - m*g*q2[2]", "column 12"),
        ("#", "column 1"),
        ("m*g*q1[2] +\n  # m*g*q2[2]\n  + 1", "line 2, column 3"),
        ("m*q1[0]#", "column 8"),
    ],
)
def test_hash_is_refused_with_its_column(text: str, at: str) -> None:
    message = error(text)
    assert message.startswith(W + ": '#' is not allowed"), message
    assert message.endswith(f"at {at}"), message


def test_the_issue_potential_with_a_hash_is_refused_in_a_spec() -> None:
    spec = (
        'name = "p"\nbodies = 2\n[parameters]\nm = 1.0\ng = 9.81\n[inertia]\n'
        'diagonal = ["m", "m"]\n[potential]\nV = "-m*g*q1[2] # - m*g*q2[2]"\n'
    )
    message = one_line_error(lambda: load_spec_text(spec, origin="s.toml"), SpecError)
    assert message == (
        "s.toml: [potential] V: '#' is not allowed (expressions have no comments; it would end "
        "the expression) at column 12"
    )


@pytest.mark.parametrize(
    ("text", "char", "at"),
    [
        ("ｍ*q1[0]", "'ｍ' (U+FF4D)", "column 1"),
        ("m*q₁[0]", "'₁' (U+2081)", "column 4"),
        ("m*\u00a0q1[0]", "'\\xa0' (U+00A0)", "column 3"),
        ("m + q1[0]\x00", "'\\x00' (U+0000)", "column 10"),
        ("m +\n 𝐪1[0]", "'𝐪' (U+1D42A)", "line 2, column 2"),
    ],
)
def test_characters_outside_ascii_are_refused(text: str, char: str, at: str) -> None:
    message = error(text)
    assert f"character {char} is not allowed (expressions are ASCII) at {at}" in message


@pytest.mark.parametrize(
    "text",
    ["sqrt(3)**(10**8)", "(sqrt(3)*q1[0])**(10**8)", "((2*q1[0])**1000)**1000", "3**(10**9)"],
)
@pytest.mark.timeout(30)  # computing any of these powers exactly would take far longer
def test_huge_powers_are_refused_before_sympy_computes_them(text: str) -> None:
    message = error(text)
    assert "is too large: its exact value would have about" in message
    assert "more than the limit of 1000" in message and "column" in message


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        (
            "sqrt(3)**(10**5)",
            ["power 'sqrt(3)**(10**5)' is too large", "limit of 1000", "column 8"],
        ),
        ("0.0**-1", ["'0.0**-1' is not finite", "column 1"]),
        ("0.0**-1.5", ["'0.0**-1.5' is not finite", "column 1"]),
        ("exp(1000)*m", ["'exp(1000)' is about 1.970e+434, beyond the range", "1.8e308"]),
        ("10**400/10**399", ["'10**400' holds the number 1.000e+400, beyond the range"]),
        ("q1[0]*1e200**2", ["'1e200**2' holds the number", "column 7"]),
        ("m*2**1024", ["'2**1024'", "beyond the range of a double", "column 3"]),
        ("sqrt(-1)*m", ["'sqrt(-1)' is not real", "column 1"]),
        ("q1[0] + log(-2)", ["'log(-2)' is not real", "column 9"]),
        ("sqrt(-1 - q1[0]**2)", ["is not real", "column 1"]),
        ("m*" + "9" * 401, ["has more than the limit of 400 digits", "column 3"]),
        (  # found by the slow fuzz: the number itself ran to 230 digits of exponent
            "2.2396655148204807e+288 ** (0 - -3.4680054267025125e+227)",
            ["holds the number 5.957e+<231 digits>, beyond the range of a double"],
        ),
    ],
)
def test_limit_errors_are_one_line_naming_key_token_column_and_limit(
    text: str, fragments: list[str]
) -> None:
    message = error(text)
    assert message.startswith(W + ": ") and len(message) < 300, message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_numbers_within_the_limits_are_exact() -> None:
    """What the limits leave alone keeps its exact value (checked against SymPy directly)."""
    q = q_symbol(1, 0)
    assert parse("0.0**2 + q1[0]") == sp.Float(0.0) + q
    assert parse("2**1023*q1[0]") == sp.Integer(2) ** 1023 * q
    assert parse("sqrt(3)**(10**2)*q1[0]") == sp.Integer(3) ** 50 * q
    assert parse("(1/3)**600*q1[0]") == sp.Rational(1, 3**600) * q
    assert parse("q1[0]**(10**300)") == q ** (sp.Integer(10) ** 300)
    assert parse("1e-320**2*q1[0]") == sp.Float(1e-320) ** 2 * q  # below the smallest double


def test_errors_inside_multiline_expressions_stay_one_line() -> None:
    """A token spanning lines is shown without its line breaks."""
    message = error("m*sin(\n  q1)")
    assert "sin() argument 1 'q1' must be a scalar" in message
    message = error("m + (q1\n  )")
    assert "\n" not in message
