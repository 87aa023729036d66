"""Property-based fuzzing of the front door with Hypothesis (issue 8).

Properties:
- the expression parser, on any text, returns a scalar SymPy expression or raises SpecError,
  in one line starting with the key, within the deadline, and never runs the text as code
  (eval, exec and compile other than to an AST are trapped while it parses);
- whole specs, as TOML text or as Python values, load or raise SpecError, the same way;
- every accepted well-typed expression emits C that compiles with the strict flags, and its
  C gradient agrees with the reference backend's (SymPy + lambdify, independent of the
  printers) at a random point: equal where both are finite (to 1e-9 relative, or 1e-7 of the
  largest term for ill-conditioned sums), non-finite in the same components. Expressions are
  batched into one system per example (each on its own three bodies) to bound compile time.

The default run has a fixed budget and a fixed seed (`derandomize`), so it is reproducible;
`python -m pytest -m slow tests/test_fuzz.py` runs the same properties with random seeds and
ten times the examples.
"""

from __future__ import annotations

import ast
import builtins
import contextlib
import os
import re
import time
import types
from collections.abc import Callable, Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sympy as sp
from fuzz_strategies import (
    PARAMETERS,
    expression_text,
    random_point,
    small_expression,
    spec_values,
    toml_text,
    valid_expression,
)
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from reliability_helpers import compile_strictly

from s2gen.emit import emit
from s2gen.printing.c import LiteralError
from s2gen.runtime import get_backend
from s2gen.spec import define_system, load_spec_text, parse_expression
from s2gen.system import SpecError

W = "fuzz.toml: [potential] V"
PWNED = Path("/tmp/s2gen-fuzz-pwned")


def budget(examples: int, seconds: float, slow: bool = False) -> Callable[[Any], Any]:
    """Hypothesis settings: the default run is derandomized (reproducible), the slow one not."""
    return settings(
        max_examples=examples * (10 if slow else 1),
        deadline=timedelta(seconds=seconds),
        derandomize=not slow,
        database=None,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.filter_too_much,
            HealthCheck.function_scoped_fixture,  # tmp_path: a folder per example is not needed
        ],
        print_blob=True,
    )


class Evaluated(BaseException):
    """Raised by the trapped builtins: something tried to run text as code."""


@contextlib.contextmanager
def no_code_execution() -> Iterator[None]:
    """Trap eval, exec and compile (except compile to an AST, which is what ast.parse does)."""
    saved = builtins.eval, builtins.exec, builtins.compile

    def trapped(source: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(source, types.CodeType) and os.path.isfile(source.co_filename):
            return saved[1](source, *args, **kwargs)  # an import running a module's code
        raise Evaluated(repr(source)[:200])

    def compile_ast(
        source: Any, filename: Any, mode: str, flags: int = 0, *a: Any, **k: Any
    ) -> Any:
        if not flags & ast.PyCF_ONLY_AST:
            raise Evaluated(repr(source))
        return saved[2](source, filename, mode, flags, *a, **k)

    builtins.eval, builtins.exec, builtins.compile = trapped, trapped, compile_ast  # type: ignore[assignment]
    try:
        yield
    finally:
        builtins.eval, builtins.exec, builtins.compile = saved


def check_error(message: str, prefix: str) -> str:
    """A one-line message from `prefix`; returns its kind (for the statistics)."""
    assert "\n" not in message and "\r" not in message, repr(message)
    assert message.startswith(prefix), message
    assert len(message) < 400, message
    rest = message[len(prefix) :].lstrip(": ")
    return re.split(r"['\"0-9(]", rest, maxsplit=1)[0].strip()[:50]


def parse_one(text: str) -> None:
    start = time.perf_counter()
    with no_code_execution():
        try:
            result = parse_expression(text, n=3, parameters=list(PARAMETERS), where=W)
        except SpecError as exc:
            event(f"refused: {check_error(str(exc), W)}")
            result = None
    elapsed = time.perf_counter() - start
    assert elapsed < 5.0, (text, elapsed)
    if result is not None:
        event("accepted")
        assert isinstance(result, sp.Expr) and not isinstance(result, sp.MatrixBase)
        assert not result.has(sp.zoo, sp.oo, sp.S.NegativeInfinity, sp.nan, sp.I)
    assert not PWNED.exists()


@budget(400, 5.0)
@given(expression_text)
def test_parser_fuzz(text: str) -> None:
    parse_one(text)


@pytest.mark.slow
@budget(400, 5.0, slow=True)
@given(expression_text)
def test_parser_fuzz_long(text: str) -> None:
    parse_one(text)


@budget(200, 5.0)
@given(valid_expression)
def test_parser_fuzz_well_typed(text: str) -> None:
    parse_one(text)


def load_one(call: Callable[[], object], prefix: str) -> None:
    start = time.perf_counter()
    with no_code_execution():
        try:
            call()
            event("accepted")
        except SpecError as exc:
            event(f"refused: {check_error(str(exc), prefix)}")
    assert time.perf_counter() - start < 5.0
    assert not PWNED.exists()


@budget(150, 5.0)
@given(toml_text())
def test_toml_spec_fuzz(text: str) -> None:
    load_one(lambda: load_spec_text(text, origin="fuzz.toml"), "fuzz.toml: ")


@budget(150, 5.0)
@given(spec_values())
def test_python_spec_fuzz(values: dict[str, Any]) -> None:
    load_one(lambda: define_system(**values), "<python api>: ")


@pytest.mark.slow
@budget(150, 5.0, slow=True)
@given(toml_text(), spec_values())
def test_spec_fuzz_long(text: str, values: dict[str, Any]) -> None:
    load_one(lambda: load_spec_text(text, origin="fuzz.toml"), "fuzz.toml: ")
    load_one(lambda: define_system(**values), "<python api>: ")


# ---------------------------------------------------------------- compile and agree
def _on_bodies(text: str, group: int) -> str:
    """`text` moved from bodies 1..3 to bodies 3 group + 1..3 group + 3."""
    return re.sub(r"\bq([123])\b", lambda m: f"q{3 * group + int(m.group(1))}", text)


def agree(c: np.ndarray, ref: np.ndarray, terms: np.ndarray) -> list[int]:
    """Indices where the C and reference gradients disagree: a non-finite value on one side
    only, or finite values further apart than 1e-9 relative (1e-7 of `terms`, the largest
    magnitude in the expression's evaluation, when the sum cancels)."""
    bad = []
    for k, (a, b) in enumerate(zip(c.ravel(), ref.ravel())):
        if not (np.isfinite(a) and np.isfinite(b)):
            if np.isfinite(a) != np.isfinite(b) or (np.isnan(a) != np.isnan(b)):
                bad.append(k)
            continue
        scale = max(abs(a), abs(b))
        if abs(a - b) > 1e-9 * scale and abs(a - b) > 1e-7 * terms.ravel()[k]:
            bad.append(k)
    return bad


def _term_scale(system: Any, q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The largest magnitude among the additive terms of each gradient component (a measure
    of cancellation), evaluated by lambdify on the expanded derivative."""
    from s2gen.symbols import q_symbols

    qs = q_symbols(system.n)
    values = dict(zip(qs, q.ravel()))
    values.update(dict(zip(system.parameter_symbols, p)))
    out = np.zeros(3 * system.n)
    for k, s in enumerate(qs):
        d = sp.diff(system.potential, s)
        if d == 0:
            continue
        terms = sp.Add.make_args(d)
        with np.errstate(all="ignore"):
            mags = [abs(complex(sp.N(t.xreplace(values), 20))) for t in terms]
        out[k] = max([m for m in mags if np.isfinite(m)] or [0.0])
    return out


def compile_and_agree(texts: list[str], seed: int, tmp_path: Path) -> None:
    accepted = []
    for text in texts:
        try:
            parse_expression(text, n=3, parameters=list(PARAMETERS), where=W)
        except SpecError:
            event("refused (out of range, division by zero, not real)")
            continue
        accepted.append(text)
    if not accepted:
        return
    potential = " + ".join(f"({_on_bodies(t, g)})" for g, t in enumerate(accepted))
    n = 3 * len(accepted)
    rng = np.random.default_rng(seed)
    values = dict(zip(PARAMETERS, rng.uniform(0.5, 2.0, size=3).round(3).tolist()))
    try:
        system = define_system(
            name="fz", bodies=n, parameters=values, diagonal=["m"] * n, potential=potential
        )
    except SpecError as exc:
        event("system refused")
        check_error(str(exc), "<python api>: ")
        return
    try:
        files = emit(system, "c", cache=False)
    except LiteralError as exc:  # a derivative beyond the range of a double
        event("derivative beyond double range")
        check_error(str(exc), "the number")
        return
    folder = tmp_path / f"fz{seed}"
    folder.mkdir(exist_ok=True)
    compile_strictly(files, folder)
    q = random_point(n, seed)
    p = np.array(system.parameter_values)
    with np.errstate(all="ignore"):
        c = np.asarray(get_backend(system, "c").gradient(q, p), dtype=float)
        ref = np.asarray(get_backend(system, "reference").gradient(q, p), dtype=float)
    bad = agree(c, ref, np.full(c.shape, np.inf))
    if bad:
        bad = agree(c, ref, _term_scale(system, q, p))
    finite = "all finite" if np.all(np.isfinite(ref)) else "some non-finite"
    event(f"{len(accepted)} expression(s) compiled; reference gradient {finite}")
    assert not bad, (accepted, c.ravel()[bad], ref.ravel()[bad])


@budget(10, 60.0)
@given(texts=st.lists(small_expression, min_size=4, max_size=4), seed=st.integers(0, 2**32 - 1))
def test_accepted_expressions_compile_and_agree(
    texts: list[str], seed: int, tmp_path: Path
) -> None:
    compile_and_agree(texts, seed, tmp_path)


@pytest.mark.slow
@budget(30, 60.0, slow=True)
@given(texts=st.lists(valid_expression, min_size=4, max_size=4), seed=st.integers(0, 2**32 - 1))
def test_accepted_expressions_compile_and_agree_long(
    texts: list[str], seed: int, tmp_path: Path
) -> None:
    compile_and_agree(texts, seed, tmp_path)
