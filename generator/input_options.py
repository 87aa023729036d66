"""The inputs of a driven run given on the command line: ``--input NAME=EXPR`` (an expression
in t and the parameters) and ``--inputs FILE.csv`` (one row per step).

Input: a `System`, the options' values, the number of steps, h and the start time. Output: the
inputs as an array of shape (steps, n_inputs), row k held over step k (None: none given, the
defaults); a ValueError of one line for anything wrong (an unknown input, a bad expression,
a file whose header or row count does not fit).

Example:
    >>> from s2gen.spec import define_system
    >>> s = define_system(name="p", bodies=1, parameters={"A": 2.0}, inputs={"u": 0.0,
    ...                   "v": 1.0}, diagonal=["1"], potential="u*q1[2] + v*q1[0]")
    >>> cli_inputs(s, ["u=A*t"], None, 3, 0.5, 0.0).tolist()
    [[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from s2gen.system import SpecError, System

__all__ = ["cli_inputs"]


def _expression_rows(system: System, given: list[str], times: np.ndarray) -> np.ndarray:
    import sympy as sp

    from s2gen.spec import parse_expression
    from s2gen.symbols import TIME

    names = system.inputs.names
    rows = np.tile(np.array(system.inputs.values, dtype=float), (len(times), 1))
    values = dict(zip(system.parameter_symbols, system.parameter_values))
    for item in given:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or name not in names:
            known = ", ".join(names) or "none"
            raise ValueError(f"--input {item!r}: expected NAME=EXPR with NAME an input ({known})")
        try:
            expr = parse_expression(
                text, n=0, parameters=system.parameter_names, where=f"--input {name}"
            )
        except SpecError as exc:
            raise ValueError(str(exc)) from None
        expr = sp.sympify(expr).xreplace(values)
        extra = expr.free_symbols - {TIME}
        if extra:
            raise ValueError(f"--input {name}: depends on {sorted(map(str, extra))}, not only t")
        column = np.broadcast_to(sp.lambdify(TIME, expr, "numpy")(times), times.shape)
        rows[:, names.index(name)] = column
    return rows


def _file_rows(system: System, path: str, nsteps: int) -> np.ndarray:
    names = system.inputs.names
    try:
        with Path(path).open() as f:
            header = [h.strip() for h in f.readline().split(",")]
            data = np.loadtxt(f, delimiter=",", ndmin=2)
    except (OSError, ValueError) as exc:
        raise ValueError(f"--inputs {path}: cannot read it: {exc}") from None
    if sorted(header) != sorted(names):
        raise ValueError(
            f"--inputs {path}: the header names {', '.join(header)}; expected the inputs "
            f"{', '.join(names)} (in any order)"
        )
    if data.shape != (nsteps, len(names)):
        raise ValueError(
            f"--inputs {path}: {data.shape[0]} rows of {data.shape[1]} numbers; expected "
            f"{nsteps} rows (T / h) of {len(names)}"
        )
    return np.ascontiguousarray(data[:, [header.index(n) for n in names]])


def cli_inputs(
    system: System, given: list[str], path: str | None, nsteps: int, h: float, t0: float
) -> np.ndarray | None:
    """The inputs of the module docstring (both options together are refused)."""
    if not given and path is None:
        return None
    if not system.inputs.names:
        raise ValueError(f"{system.origin}: --input/--inputs given, but the system has no inputs")
    if given and path is not None:
        raise ValueError("--input and --inputs: give one of them")
    if path is not None:
        return _file_rows(system, path, nsteps)
    return _expression_rows(system, given, t0 + h * np.arange(nsteps))
