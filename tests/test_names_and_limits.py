"""Names and sizes a System accepts (issue 8, items 5 and 8).

Before the fixes: a name with a trailing newline ("abc\\n") passed the identifier check (the
regex ended in `$`, which matches before a final newline) and wrote `abc\\n.c`; `_math` and
`_stddef` were accepted although their header guards `_MATH_H` and `_STDDEF_H` are glibc's own
(including the emitted header next to <math.h> silently dropped one of them); a 5,000-character
name failed with "File name too long" tracebacks; `System.create` with 10**9 bodies ran out of
time building 3*10**9 position symbols; a datum named `i` or `j` collided with a term's member
tables (a C redefinition, a NumPy IndexError) and data `k` and `K` of one term shared one NumPy
table, so the NumPy gradient was silently wrong (off by 1.4 against the reference).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from reliability_helpers import compile_strictly, one_line_error, random_state

from s2gen.emit import emit
from s2gen.runtime import get_backend
from s2gen.spec import define_system, load_spec_text
from s2gen.system import MAX_BODIES, MAX_NAME_LENGTH, SpecError, System


def pendula(name: str = "pend", n: int = 2) -> System:
    return define_system(
        name=name, bodies=n, parameters={"m": 1.0}, diagonal=["m"] * n, potential="-m*q1[2]"
    )


@pytest.mark.parametrize(
    ("name", "fragment"),
    [
        ("abc\n", "is not a C identifier"),
        ("abc\r\n", "is not a C identifier"),
        ("_math", "starts with '_'"),
        ("_stddef", "starts with '_'"),
        ("__x", "starts with '_'"),
        ("a" * 5000, f"has 5000 characters, more than the limit of {MAX_NAME_LENGTH}"),
        ("a" * (MAX_NAME_LENGTH + 1), f"more than the limit of {MAX_NAME_LENGTH}"),
        ("int", "reserved word"),
    ],
)
def test_bad_names_are_refused_in_one_line(name: str, fragment: str) -> None:
    message = one_line_error(lambda: pendula(name), SpecError)
    assert message.startswith("<python api>: key 'name': "), message
    assert fragment in message
    assert len(message) < 200


def test_a_toml_name_with_a_newline_is_refused() -> None:
    text = 'name = "abc\\n"\nbodies = 1\n[parameters]\n[inertia]\ndiagonal = [1]\n'
    text += '[potential]\nV = "q1[2]"\n'
    message = one_line_error(lambda: load_spec_text(text, origin="n.toml"), SpecError)
    assert message == "n.toml: key 'name': 'abc\\n' is not a C identifier"


def test_the_longest_name_emits_and_compiles(tmp_path: Path) -> None:
    system = pendula("n" * MAX_NAME_LENGTH)
    files = emit(system, "c")
    assert sorted(files) == [f"{system.name}.c", f"{system.name}.h"]
    compile_strictly(files, tmp_path)


def test_a_parameter_name_with_a_newline_is_refused_by_system_create() -> None:
    m = sp.Symbol("m", real=True)
    message = one_line_error(
        lambda: System.create(
            name="p", n=1, parameters={"m\n": 1.0}, inertia=sp.Matrix([[m]]), potential=m
        ),
        SpecError,
    )
    assert message == "<python api>: [parameters]: 'm\\n' is not an identifier"


@pytest.mark.timeout(30)  # allocating for 10^9 bodies would take far longer, or fail
def test_too_many_bodies_is_refused_before_allocating() -> None:
    inertia = sp.ImmutableSparseMatrix(10**9, 10**9, {(i, i): 1 for i in range(4)})
    message = one_line_error(
        lambda: define_system(
            name="big", bodies=10**9, parameters={}, inertia=inertia, potential="q1[2]"
        ),
        SpecError,
    )
    assert message == (
        f"<python api>: key 'bodies': 1000000000 bodies is more than the limit of {MAX_BODIES}"
    )


@pytest.mark.parametrize(
    ("names", "fragment"),
    [
        (["i"], "data.i: the name 'i' is taken by the term's table of member bodies"),
        (["j"], "data.j: the name 'j' is taken"),
        (["I"], "data.I: the name 'I' is taken"),
        (["k", "K"], "data.K: the names 'k' and 'K' differ only in case"),
    ],
)
def test_data_names_that_clash_in_the_emitted_code_are_refused(
    names: list[str], fragment: str
) -> None:
    data = {name: [1.0, 2.0] for name in names}
    message = one_line_error(
        lambda: define_system(
            name="t",
            bodies=3,
            parameters={},
            diagonal=[1, 1, 1],
            pair_terms=[{"V": "dot(qi, qj)", "pairs": [[1, 2], [2, 3]], "data": data}],
        ),
        SpecError,
    )
    assert message.startswith("<python api>: [[potential.pair]] #1 "), message
    assert fragment in message


@pytest.mark.parametrize("where", ["parameter", "datum"])
def test_names_of_the_cse_temporaries_are_refused(where: str) -> None:
    """A parameter x0 was taken for the kernels' first temporary (a real symbol x0 as well):
    the term gradient below printed p[1] where the temporary d_m*d_w belonged, silently."""
    params = {"g": 9.81, "x0": 3.0} if where == "parameter" else {"g": 9.81}
    data = {"m": [1.0, 2.0], "w": [0.5, 0.25], **({"x0": [1.0, 2.0]} if where == "datum" else {})}
    message = one_line_error(
        lambda: define_system(
            name="tmp",
            bodies=2,
            parameters=params,
            diagonal=[1, 1],
            body_terms=[{"V": "m*w*q[0] + g*q[2]", "data": data}],
        ),
        SpecError,
    )
    assert "'x0' is reserved (the emitted code names its temporaries x0, x1, ...)" in message
    assert ("[parameters]" if where == "parameter" else "[[potential.body]] #1 data.x0") in message


def test_names_that_the_emitted_code_also_uses_work_end_to_end(tmp_path: Path) -> None:
    """Data and parameters named like the kernels' own arguments and locals (v, g, p, h, m, q,
    w, t, k, mp, md, work, x, x1 as a vector): C and NumPy agree with the reference."""
    params = {"v": 0.5, "g": 9.81, "p": 2.0, "h": 0.1, "x": 3.0, "work": 1.5, "mp": 0.7}
    body_data = {
        "m": [1.0, 2.0, 3.0],
        "w": [0.5, 0.25, 2.0],
        "x1": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
    }
    pair_data = {"t": [1.0, 2.0], "k": [3.0, 4.0], "md": [0.1, 0.2], "x0_": [[0, 0, 1], [1, 0, 0]]}
    system = define_system(
        name="clash",
        bodies=3,
        parameters=params,
        diagonal=["p", 2, "x"],
        potential="v*g*q1[2] + h*x*q2[0] + work*mp*q3[1]",
        body_terms=[{"V": "m*w*dot(x1, q) + g*q[2]", "data": body_data}],
        pair_terms=[
            {"V": "t*k*dot(qi, qj) + md*dot(x0_, qi - qj)", "pairs": "chain", "data": pair_data}
        ],
    )
    compile_strictly(emit(system, "c"), tmp_path)
    q, w = random_state(3, 7)
    p = np.array(system.parameter_values)
    ref = get_backend(system, "reference")
    for backend in ("c", "numpy"):
        be = get_backend(system, backend)
        np.testing.assert_allclose(be.gradient(q, p), ref.gradient(q, p), rtol=1e-13, atol=1e-13)
        assert be.energy(q, w, p) == pytest.approx(ref.energy(q, w, p), rel=1e-13)
