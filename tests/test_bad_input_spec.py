"""The bad-input catalog of the spec and the Python API (issue 8).

Each case is one bad input through a front door: TOML text (`load_spec_text`), the Python
API (`define_system`, `System.create`, `simulate`, `Model`) or, for a few, the command line
(`s2gen generate`). Each must fail with the documented error class (SpecError, a ValueError;
ValueError for run arguments; exit status 2 on the command line) within seconds, in exactly
one line that names the file or origin, the key and the offending token, with no traceback.
The command line's own arguments and output paths have their own catalog
(tests/test_bad_input_cli.py).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.cli import main
from s2gen.emit import emit_angles
from s2gen.reference import problem_from_system
from s2gen.runtime import Options, simulate
from s2gen.spec import define_system, load_spec_text
from s2gen.system import MAX_BODIES, SpecError, System

ORIGIN = "catalog.toml"
API = "<python api>"

BASE = """\
name = "cat"
bodies = 2
[parameters]
m = 1.0
g = 9.81
k = 2.0
[inertia]
diagonal = ["m", "m"]
[potential]
V = "-m*g*q1[2] - m*g*q2[2]"
[initial]
q = [[0, 0, 1], [1, 0, 0]]
omega = [[0, 1, 0], [0, 0, 1]]
[run]
h = 0.01
T = 1.0
"""

TERMS = BASE.replace(
    'V = "-m*g*q1[2] - m*g*q2[2]"\n',
    'V = "-m*g*q1[2]"\n[[potential.pair]]\nV = "kk*dot(qi, qj)"\npairs = [[1, 2]]\n'
    "[potential.pair.data]\nkk = [1.0]\n",
)

DRIVEN = (
    BASE + '[inputs]\nu = 0.0\n[forces]\nF1 = "u*cross(e3, q1)"\n[[forces.body]]\n'
    'F = "-c*cross(w, q)"\n[forces.body.data]\nc = [0.1, "k"]\n'
)


def edit(base: str, old: str, new: str) -> str:
    """`base` with `old` replaced by `new` (which must be there: a typo is a test error)."""
    assert old in base, old
    return base.replace(old, new)


def test_the_bases_are_valid() -> None:
    """Every case below changes one thing in a spec that loads."""
    assert load_spec_text(BASE, origin=ORIGIN).n == 2
    assert len(load_spec_text(TERMS, origin=ORIGIN).terms) == 1
    assert len(load_spec_text(DRIVEN, origin=ORIGIN).forces) == 2


# (id, TOML text, fragments that must all be in the message after "catalog.toml: ")
TOML_CASES: list[tuple[str, str, list[str]]] = [
    # --- spec keys
    ("unknown top key", 'colour = "red"\n' + BASE, ["top level: unknown key 'colour'"]),
    ("missing name", edit(BASE, 'name = "cat"\n', ""), ["missing required key 'name'"]),
    ("TOML syntax", edit(BASE, "bodies = 2", "bodies = = 2"), ["TOML syntax error", "line 2"]),
    ("bodies zero", edit(BASE, "bodies = 2", "bodies = 0"), ["key 'bodies'", "got 0"]),
    ("bodies float", edit(BASE, "bodies = 2", "bodies = 2.5"), ["key 'bodies'", "got 2.5"]),
    (
        "bodies beyond the limit",
        edit(BASE, "bodies = 2", "bodies = 1000000000"),
        ["key 'bodies': 1000000000 bodies is more than the limit of", str(MAX_BODIES)],
    ),
    (
        "run not a table",
        "run = 3\n" + edit(BASE, "[run]\nh = 0.01\nT = 1.0\n", ""),
        ["'run' must be a table [run], got 3"],
    ),
    # --- names
    (
        "name with a newline",
        edit(BASE, 'name = "cat"', 'name = "cat\\n"'),
        ["key 'name': 'cat\\n' is not a C identifier"],
    ),
    ("name _math", edit(BASE, '"cat"', '"_math"'), ["key 'name': '_math' starts with '_'"]),
    ("name _stddef", edit(BASE, '"cat"', '"_stddef"'), ["'_stddef' starts with '_'", "_STDDEF_H"]),
    (
        "name of 5000 characters",
        edit(BASE, '"cat"', '"' + "a" * 5000 + '"'),
        ["key 'name'", "has 5000 characters, more than the limit of 64"],
    ),
    ("name a keyword", edit(BASE, '"cat"', '"while"'), ["'while' is a reserved word"]),
    ("name from a digit", edit(BASE, '"cat"', '"3body"'), ["'3body' is not a C identifier"]),
    # --- inertia
    (
        "inertia M and diagonal",
        edit(BASE, "[inertia]\n", '[inertia]\nM = [["m", 0], [0, "m"]]\n'),
        ["[inertia]: give exactly one of 'M' and 'diagonal' (got both)"],
    ),
    (
        "diagonal too short",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = ["m"]'),
        ["[inertia] diagonal: expected 2 entries (one per body), got 1"],
    ),
    (
        "diagonal negative",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = ["m", "-m"]'),
        ["[inertia] M is not positive definite", "smallest eigenvalue -1"],
    ),
    (
        "M not symmetric",
        edit(BASE, 'diagonal = ["m", "m"]', 'M = [["m", 1], [0, "m"]]'),
        ["[inertia] M is not symmetric: M[1][2] = 1 but M[2][1] = 0"],
    ),
    (
        "inertia depends on q",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = ["m*q1[0]", "m"]'),
        ["[inertia] diagonal[1]: 'q1' is not allowed here", "column 3"],
    ),
    (
        "inertia divides by zero",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = ["m", "m/0"]'),
        ["[inertia] diagonal[2]: division by zero: '0' is 0", "column 2"],
    ),
    (
        "inertia with a hash",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = ["m # heavy", "m"]'),
        ["[inertia] diagonal[1]: '#' is not allowed", "column 3"],
    ),
    (
        "M row too short",
        edit(BASE, 'diagonal = ["m", "m"]', 'M = [["m", 0], ["m"]]'),
        ["[inertia] M[2]: expected 2 entries, got 1"],
    ),
    # --- potential
    (
        "potential with a hash",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"-m*g*q1[2] # - m*g*q2[2]"'),
        ["[potential] V: '#' is not allowed", "column 12"],
    ),
    (
        "potential huge power",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"sqrt(3)**(10**8)*q1[0]"'),
        ["[potential] V: power 'sqrt(3)**(10**8)' is too large", "limit of 1000", "column 8"],
    ),
    (
        "potential 0.0**-1",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"q1[0] + 0.0**-1"'),
        ["[potential] V: '0.0**-1' is not finite", "column 9"],
    ),
    (
        "potential complex",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"sqrt(-1)*q1[0]"'),
        ["[potential] V: 'sqrt(-1)' is not real", "column 1"],
    ),
    (
        "potential beyond double range",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"exp(1000)*q1[0]"'),
        ["[potential] V: 'exp(1000)' is about 1.970e+434, beyond the range of a double"],
    ),
    (
        "potential body 3 of 2",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"q3[0]"'),
        ["[potential] V: no body 'q3': the bodies are q1..q2", "column 1"],
    ),
    (
        "potential __import__",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', "\"__import__('os').system('true')\""),
        ["[potential] V: attribute access \"__import__('os').system\" is not allowed", "column 1"],
    ),
    (
        "potential full-width letter",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"-ｍ*g*q1[2]"'),
        ["[potential] V: character 'ｍ' (U+FF4D) is not allowed", "column 2"],
    ),
    (
        "potential 501-digit literal",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"1' + "0" * 500 + '*q1[0]"'),
        ["[potential] V: number '100000000000...' has more than the limit of 400 digits"],
    ),
    (
        "potential a vector",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"q1 + q2"'),
        ["[potential] V: the expression 'q1 + q2' is a vector, but a scalar is required"],
    ),
    (
        "potential missing",
        edit(BASE, 'V = "-m*g*q1[2] - m*g*q2[2]"\n', ""),
        ["[potential]: missing required key 'V'"],
    ),
    (
        "potential a boolean",
        edit(BASE, 'V = "-m*g*q1[2] - m*g*q2[2]"', "V = true"),
        ["[potential] V: expected an expression string or a SymPy scalar, got True"],
    ),
    (
        "potential infinite literal",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"1e999*q1[0]"'),
        ["[potential] V: number '1e999' is not finite", "column 1"],
    ),
    (
        "potential a 5000-character name",
        edit(BASE, '"-m*g*q1[2] - m*g*q2[2]"', '"' + "a" * 5000 + '*q1[0]"'),
        ["[potential] V: unknown name 'aaaaaaaaaa", "...' at column 1"],
    ),
    (
        # a string is a per-body expression (chains), read by the parser and its limits
        "diagonal a 400-digit string (found by the fuzzer)",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = "' + "9" * 400 + '"'),
        ["[inertia] diagonal: '99999", "...' holds the number 1.000e+400, beyond the range"],
    ),
    # --- parameters
    ("parameter pi", edit(BASE, "k = 2.0", "pi = 3.0"), ["[parameters] pi: 'pi' is a reserved"]),
    (
        "parameter a string",
        edit(BASE, "k = 2.0", 'k = "abc"'),
        ["[parameters] k: expected a number, got 'abc'"],
    ),
    (
        "parameter nan",
        edit(BASE, "k = 2.0", "k = nan"),
        ["[parameters] k: value nan is not finite"],
    ),
    ("parameter q1", edit(BASE, "k = 2.0", "q1 = 2.0"), ["[parameters] q1: 'q1' is a reserved"]),
    (
        "parameter a keyword",
        edit(BASE, "k = 2.0", "lambda = 2.0"),
        ["[parameters] lambda: 'lambda' is a reserved word"],
    ),
    (
        "parameter named like a temporary",
        edit(BASE, "k = 2.0", "x0 = 2.0"),
        ["[parameters]: 'x0' is reserved (the emitted code names its temporaries x0, x1, ...)"],
    ),
    # --- initial state
    (
        "initial q too few",
        edit(BASE, "q = [[0, 0, 1], [1, 0, 0]]", "q = [[0, 0, 1]]"),
        ["[initial] q: expected 2 vectors (one per body), got 1"],
    ),
    (
        "initial q not unit",
        edit(BASE, "q = [[0, 0, 1], [1, 0, 0]]", "q = [[0, 0, 2], [1, 0, 0]]"),
        ["[initial] q1: length 2 is not a unit vector"],
    ),
    (
        "initial q complex",
        edit(BASE, "q = [[0, 0, 1], [1, 0, 0]]", 'q = [[0, "sqrt(-1)", 1], [1, 0, 0]]'),
        ["[initial] q[1][2]: 'sqrt(-1)' is not real", "column 1"],
    ),
    (
        "initial q without omega",
        edit(BASE, "omega = [[0, 1, 0], [0, 0, 1]]\n", ""),
        ["[initial]: give both 'q' and 'omega' (or neither)"],
    ),
    (
        "initial omega nan",
        edit(BASE, "omega = [[0, 1, 0], [0, 0, 1]]", "omega = [[0, nan, 0], [0, 0, 1]]"),
        ["[initial] omega[1][2]: value nan is not finite"],
    ),
    (
        "initial q two components",
        edit(BASE, "q = [[0, 0, 1], [1, 0, 0]]", "q = [[0, 1], [1, 0, 0]]"),
        ["[initial] q[1]: expected 3 components, got 2"],
    ),
    # --- run settings
    ("run h negative", edit(BASE, "h = 0.01", "h = -0.01"), ["[run] h: expected a positive"]),
    (
        "run unknown method",
        edit(BASE, "T = 1.0", 'T = 1.0\nmethod = "rk5"'),
        ["[run] method: unknown method 'rk5'"],
    ),
    ("run unknown key", edit(BASE, "T = 1.0", "T = 1.0\nsteps = 10"), ["unknown key 'steps'"]),
    ("run T infinite", edit(BASE, "T = 1.0", "T = inf"), ["[run] T: expected a positive number"]),
    # --- terms and data
    (
        "datum named i",
        edit(edit(TERMS, "kk = [1.0]", "i = [1.0]"), '"kk*dot(qi, qj)"', '"i*dot(qi, qj)"'),
        ["[[potential.pair]] #1 data.i: the name 'i' is taken by the term's table"],
    ),
    (
        "data differing in case",
        edit(TERMS, "kk = [1.0]", "kk = [1.0]\nKK = [2.0]"),
        ["[[potential.pair]] #1 data.KK: the names 'kk' and 'KK' differ only in case"],
    ),
    (
        "datum named like a temporary",
        edit(TERMS, "kk = [1.0]", "kk = [1.0]\nx3 = [2.0]"),
        ["[[potential.pair]] #1 data.x3: the name 'x3' is reserved"],
    ),
    (
        "pair with itself",
        edit(TERMS, "pairs = [[1, 2]]", "pairs = [[1, 1]]"),
        ["[[potential.pair]] #1 pairs[1]: the pair [1, 1] joins body 1 with itself"],
    ),
    (
        "body term body 3 of 2",
        TERMS + '[[potential.body]]\nV = "q[2]"\nbodies = [3]\n',
        ["[[potential.body]] #1 bodies[1]: body 3 is not one of 1..2"],
    ),
    (
        "data one value too many",
        edit(TERMS, "kk = [1.0]", "kk = [1.0, 2.0]"),
        ["[[potential.pair]] #1 data.kk: expected 1 values (one per listed pair), got 2"],
    ),
    (
        "datum pi",
        edit(TERMS, "kk = [1.0]", "kk = [1.0]\npi = [2.0]"),
        ["[[potential.pair]] #1 data.pi: data name 'pi' is a reserved name"],
    ),
    (
        "term uses a global position",
        edit(TERMS, '"kk*dot(qi, qj)"', '"kk*q1[0]"'),
        ["[[potential.pair]] #1 V: the global position 'q1' is not allowed", "column 4"],
    ),
    (
        "cutoff on a listed pair",
        edit(TERMS, "pairs = [[1, 2]]", "pairs = [[1, 2]]\ncutoff = 0.1"),
        ["[[potential.pair]] #1 cutoff: must be a positive distance, on a term over all pairs"],
    ),
    (  # the emitted code squares the cutoff: 1e300 overflowed while printing
        "cutoff beyond any distance on the sphere",
        edit(
            BASE,
            'V = "-m*g*q1[2] - m*g*q2[2]"\n',
            'V = "-m*g*q1[2]"\n[[potential.pair]]\nV = "k*dot(qi, qj)"\npairs = "all"\n'
            "cutoff = 1e300\n",
        ),
        ["[[potential.pair]] #1: cutoff must be a positive distance of at most 1e+100", "1e+300"],
    ),
    (  # was projected away at any size, while q_i has the 1e-3 limit
        "omega along q",
        edit(BASE, "omega = [[0, 1, 0], [0, 0, 1]]", "omega = [[0, 1, 0.5], [0, 0, 1]]"),
        ["[initial] omega1: its component 0.5 along q1 is more than 0.001 of max(1, |omega1|)"],
    ),
    (
        "term with a hash",
        edit(TERMS, '"kk*dot(qi, qj)"', '"kk*dot(qi, qj) # spring"'),
        ["[[potential.pair]] #1 V: '#' is not allowed", "column 16"],
    ),
    # --- driven systems: time, inputs, forces
    (
        "velocity in a potential",
        edit(DRIVEN, 'V = "-m*g*q1[2] - m*g*q2[2]"', 'V = "-m*g*q1[2] + dot(w1, q2)"'),
        ["[potential] V: the angular velocity 'w1' is not allowed here", "column 18"],
    ),
    (
        "velocity in a potential term",
        edit(
            DRIVEN, 'V = "-m*g*q1[2] - m*g*q2[2]"', 'V = "0"\n[[potential.body]]\nV = "dot(w, q)"'
        ),
        ["[[potential.body]] #1 V: the angular velocity 'w' is not allowed here", "column 5"],
    ),
    (
        "time in the inertia",
        edit(DRIVEN, 'diagonal = ["m", "m"]', 'diagonal = ["m*(1 + t)", "m"]'),
        ["[inertia] diagonal[1]: 't' is not allowed here (only numbers and parameters)"],
    ),
    (
        "time in an initial value",
        edit(DRIVEN, "omega = [[0, 1, 0], [0, 0, 1]]", 'omega = [[0, "t", 0], [0, 0, 1]]'),
        ["[initial] omega[1][2]: 't' is not allowed here"],
    ),
    (
        "input clashes with a parameter",
        edit(DRIVEN, "u = 0.0", "k = 0.0"),
        ["[inputs] k: the input 'k' clashes with the parameter k"],
    ),
    ("input named t", edit(DRIVEN, "u = 0.0", "t = 0.0"), ["[inputs] t: the name 't' is reserved"]),
    (
        "input named like a velocity",
        edit(DRIVEN, "u = 0.0", "w1 = 0.0"),
        ["[inputs] w1: the name 'w1' is reserved"],
    ),
    (
        "input default not a number",
        edit(DRIVEN, "u = 0.0", 'u = "abc"'),
        ["[inputs] u: unknown name 'abc'"],
    ),
    (
        "force a scalar",
        edit(DRIVEN, '"u*cross(e3, q1)"', '"u*q1[2]"'),
        ["[forces] F1: the expression 'u*q1[2]' is a scalar, but a force is a 3-vector"],
    ),
    (
        "force with an unknown name",
        edit(DRIVEN, '"u*cross(e3, q1)"', '"v*cross(e3, q1)"'),
        ["[forces] F1: unknown name 'v' at column 1"],
    ),
    (
        "force on a body that does not exist",
        edit(DRIVEN, "F1 = ", "F3 = "),
        ["[forces] F3: no body 3: the bodies are 1..2"],
    ),
    (
        "force with an unknown key",
        edit(DRIVEN, "F1 = ", "G1 = "),
        ["[forces]: unknown key 'G1' (allowed: F1..F2, body, pair)"],
    ),
    (
        "force on a velocity that does not exist",
        edit(DRIVEN, '"u*cross(e3, q1)"', '"u*cross(w3, q1)"'),
        ["[forces] F1: no body 'w3': the bodies are w1..w2", "column 9"],
    ),
    (
        "force term with a global velocity",
        edit(DRIVEN, '"-c*cross(w, q)"', '"-c*cross(w1, q)"'),
        ["[[forces.body]] #1 F: the global angular velocity 'w1' is not allowed", "column 10"],
    ),
    (
        "force term without F",
        edit(DRIVEN, 'F = "-c*cross(w, q)"', 'G = "-c*cross(w, q)"'),
        ["[[forces.body]] #1: unknown key 'G' (allowed: F, bodies, data)"],
    ),
    (
        "force term datum named w",
        edit(DRIVEN, 'c = [0.1, "k"]', 'c = [0.1, "k"]\nw = [1, 2]'),
        ["[[forces.body]] #1 data.w: the name 'w' is taken"],
    ),
    (
        "force term datum named like a component of w",
        edit(DRIVEN, 'c = [0.1, "k"]', 'c = [0.1, "k"]\nw_0 = [1, 2]'),
        [
            "[[forces.body]] #1 data.w_0: the datum uses the symbol w_0",
            "a component of the term's angular velocity w",
        ],
    ),
    (
        "force term on a body that does not exist",
        edit(DRIVEN, 'F = "-c*cross(w, q)"', 'F = "-c*cross(w, q)"\nbodies = [1, 3]'),
        ["[[forces.body]] #1 bodies[2]: body 3 is not one of 1..2"],
    ),
    (
        "forces not a table",
        edit(BASE, 'name = "cat"', 'name = "cat"\nforces = 3'),
        ["'forces' must be a table [forces], got 3"],
    ),
    # --- per-body data ([data])
    ("data one value short", BASE + "[data]\nc = [1.0]\n", ["[data] c: expected 2 values"]),
    (
        "data not a list",
        BASE + "[data]\nc = 3.0\n",
        ["[data] c: expected a list of 2 values (one per body), got 3.0"],
    ),
    ("data not a table", "data = [1, 2]\n" + BASE, ["'data' must be a table [data]"]),
    (
        "data file in text with no folder",
        BASE + '[data]\nc = { file = "c.npy" }\n',
        ["[data] c: file 'c.npy' is relative, and the spec text has no folder"],
    ),
    (
        "data file of unknown kind",
        BASE + '[inertia.data]\nl = { file = "/l.xlsx" }\n',
        ["[inertia] data.l: file '/l.xlsx': unknown kind '.xlsx'"],
    ),
    (
        "data named like a parameter",
        BASE + "[data]\nk = [1.0, 2.0]\n",
        ["[data] k: data name 'k' clashes with the parameter 'k'"],
    ),
    (
        "term datum named like a per-body datum",
        TERMS + "[data]\nkk = [1.0, 2.0]\n",
        ["[[potential.pair]] #1 data.kk: 'kk' is also a per-body datum of [data]"],
    ),
    (
        "per-body datum read as a parameter's name",
        edit(TERMS, "k = 2.0", "k = 2.0\nci = 1.0") + "[data]\nc = [1.0, 2.0]\n",
        ["[[potential.pair]] #1: the [data] array 'c' (read as ci)", "the parameter 'ci'"],
    ),
    (
        "data mixing numbers and 3-vectors",
        BASE + "[data]\nc = [1.0, [0, 0, 1]]\n",
        ["[data] c[2]: a 3-vector, but entry 1 is a number"],
    ),
    (
        "data 3-vector in the inertia",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = "m*r"')
        + "[data]\nr = [[1, 0, 0], [0, 1, 0]]\n",
        ["[inertia]: the datum 'r' of [data] is a 3-vector per body", "one number per body"],
    ),
    (
        "data 3-vector where a term needs a number",
        edit(TERMS, '"kk*dot(qi, qj)"', '"kk*ci*dot(qi, qj)"')
        + "[data]\nc = [[1, 0, 0], [0, 1, 0]]\n",
        ["[[potential.pair]] #1 V: the expression 'kk*ci*dot(qi, qj)' is a vector"],
    ),
    (
        "datum in both [inertia.data] and [data]",
        edit(BASE, 'diagonal = ["m", "m"]', 'diagonal = "m*r"\n[inertia.data]\nr = [1, 2]')
        + "[data]\nr = [1.0, 2.0]\n",
        ["[inertia] data.r: 'r' is also a datum of [data]"],
    ),
    ("data named t", BASE + "[data]\nt = [1.0, 2.0]\n", ["[data] t: the name 't' is time"]),
    ("data not finite", BASE + "[data]\nc = [1.0, nan]\n", ["[data] c[2]: value nan is not"]),
    (
        "data boolean",
        BASE + "[data]\nc = [true, false]\n",
        ["[data] c[1]: expected a number or a 3-vector, got True"],
    ),
]


def check_message(message: str, origin: str, fragments: list[str]) -> None:
    """One line of reasonable length, from the origin, with every fragment, no traceback."""
    assert "\n" not in message and message == message.strip(), repr(message)
    assert len(message) < 300, message
    assert message.startswith(origin + ": "), message
    assert "Traceback" not in message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


@pytest.mark.parametrize(("case", "text", "fragments"), TOML_CASES, ids=[c[0] for c in TOML_CASES])
def test_toml_spec_catalog(case: str, text: str, fragments: list[str]) -> None:
    start = time.perf_counter()
    with pytest.raises(SpecError) as info:
        load_spec_text(text, origin=ORIGIN)
    assert time.perf_counter() - start < 5.0, case
    check_message(str(info.value), ORIGIN, fragments)


def _pendulum(**changes: object) -> System:
    args: dict = {
        "name": "api",
        "bodies": 2,
        "parameters": {"m": 1.0},
        "diagonal": ["m", "m"],
        "potential": "-m*q1[2]",
    }
    args.update(changes)
    return define_system(**args)


Q0 = sp.Symbol("q1_0", real=True)

# (id, call, fragments after "<python api>: ")
API_CASES: list[tuple[str, Callable[[], object], list[str]]] = [
    (
        "bodies beyond the limit with a sparse inertia",
        lambda: _pendulum(
            bodies=10**9,
            diagonal=None,
            inertia=sp.ImmutableSparseMatrix(10**9, 10**9, {(0, 0): 1, (1, 1): 1}),
        ),
        ["key 'bodies': 1000000000 bodies is more than the limit of"],
    ),
    ("name with a newline", lambda: _pendulum(name="abc\n"), ["key 'name': 'abc\\n' is not"]),
    (
        "data of the wrong length",
        lambda: _pendulum(data={"c": [1.0, 2.0, 3.0]}),
        ["[data] c: expected 2 values (one per body), got 3"],
    ),
    (
        "data named like an input",
        lambda: _pendulum(inputs={"c": 0.0}, data={"c": [1.0, 2.0]}),
        ["[data] c: the name 'c' is also an input"],
    ),
    ("name _math", lambda: _pendulum(name="_math"), ["'_math' starts with '_'", "_MATH_H"]),
    (
        "name of 5000 characters that is not an identifier",
        lambda: _pendulum(name="-" * 5000),
        ["key 'name': '-----", "...' is not a C identifier"],
    ),
    (
        "potential with I",
        lambda: _pendulum(potential=sp.I * Q0),
        ["[potential] V: is not real (I is complex)"],
    ),
    (
        "potential with a complex constant",
        lambda: _pendulum(potential=Q0 + sp.Pow(-8, sp.Rational(1, 3))),
        ["[potential] V: is not real ((-1)**(1/3) is complex)"],
    ),
    (
        "parameters a list",
        lambda: _pendulum(parameters=[1.0, 2.0]),
        ["[parameters]: expected a table of name = number"],
    ),
    (
        "inertia of the wrong shape",
        lambda: _pendulum(diagonal=None, inertia=sp.eye(3)),
        ["[inertia] M: expected a 2x2 matrix, got (3, 3)"],
    ),
    (
        "body terms not a list",
        lambda: _pendulum(body_terms={"V": "q[2]"}),
        ["[[potential.body]]: expected a list of term tables"],
    ),
    (
        "initial q a NaN array",
        lambda: _pendulum(
            initial_q=np.array([[0.0, 0.0, np.nan], [1.0, 0.0, 0.0]]),
            initial_omega=np.zeros((2, 3)),
        ),
        ["[initial] q[1][3]: value nan is not finite"],
    ),
    ("run not a table", lambda: _pendulum(run=5), ["[run]: expected a table, got 5"]),
    (
        "parameter with a newline through System.create",
        lambda: System.create(
            name="p",
            n=1,
            parameters={"m\n": 1.0},
            inertia=sp.Matrix([[1]]),
            potential=sp.Integer(0),
        ),
        ["[parameters]: 'm\\n' is not an identifier"],
    ),
    (
        "parameter name with a line break (found by the fuzzer)",
        lambda: _pendulum(parameters={"m": 1.0, "a\rb": 2.0}),
        ["[parameters] 'a\\rb': 'a\\rb' is not an identifier"],
    ),
    (
        "datum name with a line break",
        lambda: _pendulum(
            pair_terms=[{"V": "dot(qi, qj)", "pairs": "chain", "data": {"c\n": [1.0]}}]
        ),
        ["[[potential.pair]] #1 data.'c\\n': data name 'c\\n' is not an identifier"],
    ),
    (
        "datum I through the API",
        lambda: _pendulum(
            pair_terms=[{"V": "I*dot(qi, qj)", "pairs": "chain", "data": {"I": [1.0]}}]
        ),
        ["[[potential.pair]] #1 data.I: the name 'I' is taken"],
    ),
    (
        "parameter named like a velocity",
        lambda: _pendulum(parameters={"m": 1.0, "w2": 1.0}),
        ["[parameters] w2: 'w2' is a reserved name (q1.., w1.., e1..e3"],
    ),
    (
        "force of SymPy entries with a wrong shape",
        lambda: _pendulum(forces={"F1": sp.Matrix([[1, 0], [0, 1]])}),
        ["[forces] F1: a force is a 3-vector, got a (2, 2) matrix"],
    ),
    (
        "force of SymPy entries in an unknown symbol",
        lambda: _pendulum(forces={"F2": [0, 0, sp.Symbol("zeta", real=True)]}),
        ["[forces] F2: depends on zeta, which is not one of q1..q2, w1..w2, t, an input"],
    ),
    (
        "time in the inertia through SymPy",
        lambda: _pendulum(diagonal=None, inertia=sp.diag(sp.Symbol("t", real=True), 1)),
        ["[inertia] M[1][1]: depends on t, but the inertia must be constant"],
    ),
    (
        "input default not finite",
        lambda: _pendulum(inputs={"u": float("inf")}),
        ["[inputs] u: value inf is not finite"],
    ),
    (
        "a driven system has no angle form yet",
        lambda: emit_angles(_pendulum(potential="-m*cos(t)*q1[2]"), "numpy", cache=False),
        ["[potential] V: t: emitting numpy code (angles form) for driven systems", "not supported"],
    ),
    (
        "a driven system has no reference problem yet",
        lambda: problem_from_system(_pendulum(forces={"F2": "cross(e3, q2)"})),
        ["[forces] F2: building the reference problem for driven systems"],
    ),
]


@pytest.mark.parametrize(("case", "call", "fragments"), API_CASES, ids=[c[0] for c in API_CASES])
def test_python_api_catalog(case: str, call: Callable[[], object], fragments: list[str]) -> None:
    start = time.perf_counter()
    with pytest.raises(SpecError) as info:
        call()
    assert time.perf_counter() - start < 5.0, case
    check_message(str(info.value), API, fragments)


@pytest.fixture(scope="module")
def cat() -> System:
    return load_spec_text(BASE, origin=ORIGIN)


# (id, simulate keyword arguments, fragments): ValueErrors before anything runs
SIMULATE_CASES: list[tuple[str, dict, list[str]]] = [
    (
        "method the backend lacks",
        {"method": "vi4", "backend": "reference"},
        ["method 'vi4' is not available on the reference backend"],
    ),
    ("unknown backend", {"backend": "gpu"}, ["unknown backend 'gpu'"]),
    ("unknown method", {"method": "euler"}, ["unknown method 'euler'"]),
    ("T not a whole number of steps", {"h": 0.03}, ["T=1.0 is not a whole number of steps"]),
    (
        "q0 not unit",
        {"q0": np.array([[0.0, 0.0, 1.1], [1.0, 0.0, 0.0]])},
        ["q0 of body 1 has length 1.1000000000000001, not 1"],
    ),
    ("omega0 shape", {"omega0": np.zeros((3, 3))}, ["omega0 must have shape (2, 3), got (3, 3)"]),
    (
        "tolerances far below the floor",
        {"method": "rk45", "options": Options(rtol=1e-300, atol=1e-300)},
        ["rtol = 1e-300: must lie between 2.22e-14"],
    ),
    ("parameters of the wrong length", {"params": np.ones(4)}, ["expected 3 parameter values"]),
    ("h infinite", {"h": float("inf")}, ["step size h = inf: must be a finite number"]),
]


@pytest.mark.parametrize(
    ("case", "kwargs", "fragments"), SIMULATE_CASES, ids=[c[0] for c in SIMULATE_CASES]
)
def test_simulate_catalog(cat: System, case: str, kwargs: dict, fragments: list[str]) -> None:
    args = {"method": "vi", "backend": "reference", **kwargs}
    start = time.perf_counter()
    with pytest.raises(ValueError) as info:
        simulate(cat, **args)
    assert time.perf_counter() - start < 5.0, case
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message, message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_simulate_without_an_initial_state() -> None:
    system = _pendulum()
    with pytest.raises(ValueError) as info:
        simulate(system, "vi", "reference", h=0.01, T=0.1)
    assert str(info.value) == "<python api>: no initial state ([initial] q and omega)"


CLI_CASES = [
    ("hash", TOML_CASES[[c[0] for c in TOML_CASES].index("potential with a hash")]),
    ("complex", TOML_CASES[[c[0] for c in TOML_CASES].index("potential complex")]),
    ("name", TOML_CASES[[c[0] for c in TOML_CASES].index("name _math")]),
    ("bodies", TOML_CASES[[c[0] for c in TOML_CASES].index("bodies beyond the limit")]),
    ("datum", TOML_CASES[[c[0] for c in TOML_CASES].index("datum named i")]),
]


@pytest.mark.parametrize(("case", "spec_case"), CLI_CASES, ids=[c[0] for c in CLI_CASES])
def test_cli_generate_catalog(
    case: str,
    spec_case: tuple[str, str, list[str]],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`s2gen generate` on a bad spec: exit 2, one line naming the file and key, nothing
    written."""
    _, text, fragments = spec_case
    spec = tmp_path / "bad.toml"
    spec.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    code = main(["generate", str(spec), "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 2
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith(f"error: {spec}: ")
    assert "Traceback" not in captured.err
    for fragment in fragments:
        assert fragment in captured.err, (fragment, captured.err)
    assert not out.exists()


def test_catalog_size() -> None:
    """The catalog holds at least 40 bad inputs across the front doors."""
    total = len(TOML_CASES) + len(API_CASES) + len(SIMULATE_CASES) + len(CLI_CASES) + 1
    assert total >= 40
    assert len({c[0] for c in TOML_CASES}) == len(TOML_CASES)
