"""Numbers in emitted code: exact integers and rationals beyond 64 bits, C99's missing constants
and complex numbers (issue 8, items 1 and 6).

Before the fix, `2**64*k*q1[2]` gave 0 in the C gradient (gcc truncates an integer constant
beyond 64 bits and only warns), `10**20*q1[0]` gave 7.8e18, and `sqrt(2)`, `exp(1)`, `log(2)`
or `pi/2` printed as the POSIX macros M_SQRT2, M_E, M_LN2, M_PI_2, which C99's math.h does
not define: the build failed (BuildError) and `generate` wrote C that does not compile.
Every expected value here is a closed form computed in Python, and the reference backend
(SymPy + lambdify, independent of the printers) must agree too.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from reliability_helpers import compile_strictly, gradients, one_line_error

from s2gen.emit import emit
from s2gen.printing.c import CPrinter, LiteralError, double_literal
from s2gen.printing.numpy import PyPrinter
from s2gen.runtime import get_backend
from s2gen.spec import define_system
from s2gen.system import SpecError, System

Q = np.array([[0.6, 0.0, 0.8], [0.0, 0.6, 0.8]])


def two_bodies(potential: str | sp.Expr, name: str = "lit") -> System:
    return define_system(
        name=name, bodies=2, parameters={"k": 1.5}, diagonal=[1, 1], potential=potential
    )


# (potential, the exact coefficient of its one linear term, body, component)
BIG_NUMBERS = [
    ("2**64*k*q1[2]", 2**64 * 1.5, 0, 2),
    ("10**20*q1[0]", float(10**20), 0, 0),
    ("(2**64 + 1)*q2[1]", float(2**64 + 1), 1, 1),
    ("-(3**45)*q1[1]", -float(3**45), 0, 1),
    ("q2[0]*10**30/3", 10**30 / 3, 1, 0),
    ("q1[0]*(2**70 + 1)/(2**70 + 3)", (2**70 + 1) / (2**70 + 3), 0, 0),
    ("q2[2]/(10**300)", 1e-300, 1, 2),
    ("q1[1]*2**1000/3**600", 2**1000 / 3**600, 0, 1),
]


@pytest.mark.parametrize(("potential", "coefficient", "body", "comp"), BIG_NUMBERS)
def test_exact_numbers_beyond_64_bits_reach_the_c_gradient(
    potential: str, coefficient: float, body: int, comp: int, tmp_path: Path
) -> None:
    system = two_bodies(potential)
    compile_strictly(emit(system, "c"), tmp_path)
    c, ref = gradients(system, Q)
    expected = np.zeros((2, 3))
    expected[body, comp] = coefficient
    assert np.array_equal(ref, expected), (ref, expected)
    assert np.array_equal(c, expected), (c, expected)
    p = np.array(system.parameter_values)
    assert np.array_equal(get_backend(system, "numpy").gradient(Q, p), expected)


CONSTANTS = [
    ("sqrt(2)", math.sqrt(2)),
    ("1/sqrt(2)", 1 / math.sqrt(2)),
    ("exp(1)", math.e),
    ("log(2)", math.log(2)),
    ("log(10)", math.log(10)),
    ("1/log(2)", 1 / math.log(2)),
    ("pi", math.pi),
    ("pi/2", math.pi / 2),
    ("pi/4", math.pi / 4),
    ("1/pi", 1 / math.pi),
    ("2/pi", 2 / math.pi),
    ("2/sqrt(pi)", 2 / math.sqrt(math.pi)),
    ("cos(pi/4)", math.cos(math.pi / 4)),
]


def test_constants_print_as_c99_literals(tmp_path: Path) -> None:
    """All of SymPy's math-macro constants in one system: strict C99 compiles (no M_*), and each
    coefficient of the gradient is the constant to within one rounding."""
    terms = " + ".join(
        f"({text})*q{1 + k % 2}[{k % 3}]*{k + 1}" for k, (text, _) in enumerate(CONSTANTS)
    )
    system = two_bodies(terms, name="consts")
    files = emit(system, "c")
    assert re.findall(r"\bM_[A-Z0-9_]+", files["consts.c"]) == []
    compile_strictly(files, tmp_path)
    expected = np.zeros((2, 3))
    for k, (_, value) in enumerate(CONSTANTS):
        expected[k % 2, k % 3] += value * (k + 1)
    c, ref = gradients(system, Q)
    np.testing.assert_allclose(c, expected, rtol=4e-16, atol=0)
    np.testing.assert_allclose(ref, expected, rtol=4e-16, atol=0)


def test_the_issue_spring_with_sqrt2_rest_length_builds_and_agrees(tmp_path: Path) -> None:
    """The issue's example: `k/2*(norm(q1 - q2) - sqrt(2))**2` failed to build."""
    system = two_bodies("k/2*(norm(q1 - q2) - sqrt(2))**2", name="spring")
    compile_strictly(emit(system, "c"), tmp_path)
    d = Q[0] - Q[1]
    r = np.linalg.norm(d)
    g1 = 1.5 * (r - math.sqrt(2)) * d / r
    c, ref = gradients(system, Q)
    np.testing.assert_allclose(c, [g1, -g1], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ref, [g1, -g1], rtol=1e-14, atol=1e-15)


def test_a_cube_root_means_the_same_on_every_backend(tmp_path: Path) -> None:
    """x**(1/3) is the principal root (the spec refuses (-8)**(1/3) as not real): for x < 0 the
    C gradient is NaN like the reference's, not cbrt's real root (the long fuzz found C 0.549
    against the reference's NaN for (m*q1[1])**(1/3)); for x > 0 the two agree with the closed
    form k**(1/3) x**(-2/3) / 3."""
    system = two_bodies("(k*q1[1])**(1/3) + (k*q2[1])**(1/3)", name="cube")
    compile_strictly(emit(system, "c"), tmp_path)
    q = np.array([[0.0, -0.6, 0.8], [0.0, 0.6, 0.8]])
    c, ref = gradients(system, q)
    assert np.isnan(c[0, 1]) and np.isnan(ref[0, 1])
    expected = 1.5 ** (1 / 3) * 0.6 ** (-2 / 3) / 3
    np.testing.assert_allclose([c[1, 1], ref[1, 1]], [expected, expected], rtol=1e-14)


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("sqrt(-1)*q1[0]", "'sqrt(-1)' is not real"),
        ("log(-2) + q1[0]", "'log(-2)' is not real"),
        ("(-8)**(1/3)*q1[0]", "'(-8)**(1/3)' is not real"),
        ("sqrt(-1 - q1[0]**2)", "is not real"),
    ],
)
def test_a_complex_potential_is_a_spec_error_naming_the_key(text: str, shown: str) -> None:
    message = one_line_error(lambda: two_bodies(text), SpecError)
    assert message.startswith("<python api>: [potential] V: "), message
    assert shown in message


def test_a_complex_sympy_potential_is_refused_too() -> None:
    q = sp.Symbol("q1_0", real=True)
    for potential in (sp.I * q, q * sp.sqrt(-2), q + sp.Pow(-8, sp.Rational(1, 3))):
        message = one_line_error(lambda v=potential: two_bodies(v), SpecError)
        assert message.startswith("<python api>: [potential] V: is not real"), message


def test_printers_refuse_what_is_not_a_double() -> None:
    x = sp.Symbol("x", real=True)
    for printer in (CPrinter({x: "q[0]"}), PyPrinter({x: "q[0]"})):
        with pytest.raises(LiteralError, match="complex"):
            printer.doprint(sp.I * x)
        with pytest.raises(LiteralError, match="beyond the range of a double"):
            printer.doprint(sp.Integer(10) ** 400 * x)
        with pytest.raises(LiteralError, match="beyond the range of a double"):
            printer.doprint(sp.Float("1e400") * x)
    assert CPrinter({}).doprint(sp.Float("1e-400") * x) == "0.0*x"
    assert double_literal(sp.Rational(10**400 + 1, 10**400)) == "1.0"
    assert float(double_literal(sp.Integer(2**64 + 1))) == float(2**64 + 1)


def test_a_derivative_beyond_double_range_is_a_clear_error() -> None:
    """1.5e308*q**2 is a double, its derivative 3e308 is not: emitting refuses it in one line
    (the reference would compute inf)."""
    system = two_bodies("1.5e308*q1[0]**2", name="huge")
    message = one_line_error(lambda: emit(system, "c", cache=False), LiteralError)
    assert "beyond the range of a double" in message
