"""The front doors: TOML spec files and the Python API, with a safe expression parser.

Input: a TOML file (`load_spec`), TOML text (`load_spec_text`) or Python values
(`define_system`); expressions are strings in a small, whitelisted language (`parse_expression`)
or ready-made SymPy objects.
Output: a validated `System` (built by `System.create`, which does the semantic checks), or a
`SpecError` naming the file, the key (table and key, list indices 1-based as for bodies and
the entries of M) and the offending item.

Modules: `parser` (the expression language below), `tables` (each table or argument checked
and turned into a piece of the `System`); this module holds the front doors themselves.

Expression language (parsed with `ast`, walked with an explicit whitelist; never evaluated):
numbers, unary + and -, binary + - * / **, parentheses, declared parameters, `pi`, the body
vectors `q1`..`qn` and unit axes `e1`, `e2`, `e3` (3-vectors), literal subscripts `v[0]`..`v[2]`
of a vector, and the calls `dot(a, b)`, `cross(a, b)`, `norm(a)`, `sqrt`, `exp`, `log`, `sin`,
`cos`, `tan`, `Abs`. A multi-line string may break anywhere, as inside parentheses. Lines
and columns in messages count from 1 within the expression string.

Structured potentials: besides (or instead of) the general `V`, the [potential] table may hold
one-body and pair terms, each a sum of one expression over its members::

    [potential]
    V = "..."                # optional general part when terms are given

    [[potential.body]]       # a one-body term (any number of them)
    V = "-m*g*l*dot(e3, q)"  # in the body's own vector q
    bodies = "all"           # or a list of 1-based body indices, e.g. [1, 3]; default "all"
    [potential.body.data]    # optional per-body data: one value per body of the selection
    l = [0.1, 0.2]

    [[potential.pair]]       # a pair term, in the pair's vectors qi and qj
    V = "k/2*(norm(r + l/2*qj - l/2*qi) - norm(r))**2"
    pairs = [[1, 2], [2, 3], [3, 4], [4, 1]]   # or "chain" (i, i+1) or "all" (every i < j)
                             # or "ring" (the chain and (n, 1); this list for n = 4; n >= 3)
    [potential.pair.data]    # per-pair data (not with pairs = "all": use a parameter there)
    k = [10, 20, 30, 40]
    r = [[0.1, 0, 0], [0, -0.1, 0], [-0.1, 0, 0], [0, 0.1, 0]]

    [[potential.pair]]       # over all pairs, optionally only those closer than a cutoff
    V = "4*eps*((sigma**2/dot(qi - qj, qi - qj))**6 - (sigma**2/dot(qi - qj, qi - qj))**3)"
    pairs = "all"
    cutoff = 0.1             # chord distance |qi - qj|; cell lists make the cost O(n)

Chains: the inertia per body. Instead of its n^2 entries, [inertia] may give M as
one expression per body (see `s2gen.spec.inertia`), in the parameters, per-body data, the body
index `i` (1..n) and the body count `n`: M_ii = diagonal, M_ij = scale_i scale_j
max_index_max(i,j) for i != j (the form of every chain of links; the O(n) solvers use it)::

    [inertia]
    diagonal  = "l**2*T"         # a string: one expression per body (a list: n entries)
    max_index = "T"              # optional; without it M is diagonal
    scale     = "l"              # optional, default 1
    solver    = "auto"           # optional: "auto", "dense" or "structured"
    [inertia.data]               # per-body data: one number per body
    l = [0.3, 0.25, 0.2]
    T = [1.2, 0.8, 0.5]

Per-body data: the top-level [data] table holds arrays of one number or one 3-vector per body
(`s2gen.spec.data`); every term reads them whatever its selection, a body term as `c`, a pair
term as `ci` and `cj` (the values at the pair's bodies), and the per-body inertia reads the
scalar ones by name, as it reads [inertia.data] (an alias)::

    [data]
    c = [1.0, -1.0, 0.5]
    r = { file = "radii.npy" }   # or .txt / .csv, one row per body (`s2gen.spec.files`)

A term expression sees its own vectors (`q`, or `qi` and `qj`), its data, the per-body data,
the parameters and everything above except the global `q1..qn`. A datum is a list with one entry per member, all
numbers (a scalar, symbol `name`) or all 3-vectors (usable wherever a vector is: `dot(r, qi)`,
`r[1]`; symbols `name_0..name_2`); entries are numbers or expression strings in numbers and
parameters, evaluated to floats. Data names must not clash with parameters, reserved names or
`q`, `qi`, `qj`. Terms are labelled "[[potential.body]] #k" / "[[potential.pair]] #k" (k from
1, in file order); errors name them, e.g. ``spec.toml: [[potential.pair]] #2 data.k: ...``.
A term's list and its data entries may name files, as [data] entries do: ``pairs = { file =
"bonds.csv" }``, ``data = { k = { file = "k.txt" } }``.
The Python API takes the same tables as dicts: ``define_system(..., body_terms=[{"V": ...,
"bodies": ..., "data": {...}}], pair_terms=[{"V": ..., "pairs": ..., "data": {...}}])``.

Example:
    >>> s = define_system(name="pendulum", bodies=1, parameters={"m": 1.0, "g": 9.81},
    ...                   diagonal=["m"], potential="-m*g*dot(e3, q1)")
    >>> s.potential
    -g*m*q1_2
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from s2gen.spec.data import body_data, scalar_data
from s2gen.spec.files import read_data_files, read_term_files
from s2gen.spec.forces import _forces, _inputs
from s2gen.spec.inertia import chain_inertia
from s2gen.spec.parser import RESERVED_NAMES, parse_expression
from s2gen.spec.tables import (
    _bodies,
    _check_keys,
    _inertia,
    _initial,
    _parameters,
    _potential,
    _run_settings,
)
from s2gen.spec.term_tables import _terms
from s2gen.system import INERTIA_SOLVERS, RunSettings, SpecError, System, shown
from s2gen.terms import TermData, TermKind

__all__ = [
    "RESERVED_NAMES",
    "define_system",
    "load_spec",
    "load_spec_text",
    "parse_expression",
]

API_ORIGIN = "<python api>"


# ====================================================================== the Python API
def define_system(
    *,
    name: str,
    bodies: int,
    parameters: Mapping[str, float],
    potential: str | float | sp.Expr | None = None,
    inertia: Sequence[Sequence[str | float | sp.Expr]] | sp.MatrixBase | None = None,
    diagonal: Sequence[str | float | sp.Expr] | str | sp.Expr | None = None,
    initial_q: Sequence[Sequence[str | float | sp.Expr]] | np.ndarray | None = None,
    initial_omega: Sequence[Sequence[str | float | sp.Expr]] | np.ndarray | None = None,
    run: Mapping[str, Any] | RunSettings | None = None,
    origin: str = API_ORIGIN,
    body_terms: Sequence[Mapping[str, Any]] | None = None,
    pair_terms: Sequence[Mapping[str, Any]] | None = None,
    max_index: str | sp.Expr | None = None,
    scale: str | float | sp.Expr | None = None,
    inertia_data: Mapping[str, Sequence[str | float]] | None = None,
    inertia_solver: str = "auto",
    inputs: Mapping[str, str | float] | None = None,
    forces: Mapping[str, Any] | None = None,
    force_terms: Sequence[Mapping[str, Any]] | None = None,
    data: Mapping[str, Any] | None = None,
    force_pairs: Sequence[Mapping[str, Any]] | None = None,
) -> System:
    """Build a validated System from Python values (the same rules as a TOML spec).

    Expressions may be strings (parsed safely) or SymPy objects; give exactly one of
    `inertia` (n x n) and `diagonal` (n entries, or one expression per body in the body index
    `i`, `n`, the parameters and `inertia_data`, optionally with `max_index` and `scale`:
    M_ij = scale_i scale_j max_index_max(i,j) off the diagonal; see `s2gen.spec.inertia`).
    `inertia_solver` is "auto", "dense" or "structured". `body_terms` and `pair_terms` are lists of
    dicts with the keys of a ``[[potential.body]]`` / ``[[potential.pair]]`` table (``V``,
    ``bodies`` / ``pairs`` with 1-based indices, ``data``); `potential` (the general part) may
    then be omitted. Driven systems (`s2gen.spec.forces`): `inputs` maps input names to
    defaults, `forces` the keys ``F1``.. to 3-vectors, `force_terms` is a list of dicts with
    the keys of a ``[[forces.body]]`` table (``F``, ``bodies``, ``data``), `force_pairs` of
    a ``[[forces.pair]]`` table (``Fi``, ``Fj``, ``pairs``, ``data``); potentials may then
    hold time ``t`` and the inputs. `data` maps names to per-body arrays (n numbers or n
    3-vectors; the [data] table), read by terms (potential and force terms alike) as c or
    ci, cj and by the per-body inertia.
    Raises SpecError naming `origin` and the key.

    Example:
        >>> s = define_system(name="pend", bodies=1, parameters={"m": 1.0, "l": 2.0},
        ...                   inertia=[["m*l**2"]], potential="-m*9.81*l*q1[2]",
        ...                   initial_q=[["sqrt(3)/2", 0, "1/2"]], initial_omega=[[0, 1, 0]])
        >>> s.inertia, s.q0.round(4).tolist()
        (Matrix([[l**2*m]]), [[0.866, 0.0, 0.5]])
        >>> s = define_system(name="ring", bodies=3, parameters={"m": 1.0, "k": 2.0},
        ...                   diagonal=["m"] * 3, body_terms=[{"V": "-m*q[2]"}],
        ...                   pair_terms=[{"V": "c*dot(qi, qj)", "pairs": [[1, 2], [2, 3]],
        ...                                "data": {"c": ["k", 3]}}])
        >>> [t.member_list(s.n) for t in s.terms], s.terms[1].data
        ([[(0,), (1,), (2,)], [(0, 1), (1, 2)]], (TermData(name='c', width=1, values=(2.0, 3.0)),))
        >>> s = define_system(name="rope", bodies=1000, parameters={"m": 1.0}, potential=0,
        ...                   diagonal="m*(n - i + 1)", max_index="m*(n - i + 1)")
        >>> s.structure.kind.value
        'max-index'
        >>> s = define_system(name="spun", bodies=1, parameters={"c": 0.1}, diagonal=["1"],
        ...                   inputs={"tau": 0.0}, potential="cos(t)*q1[2]",
        ...                   forces={"F1": "tau*cross(e3, q1)"},
        ...                   force_terms=[{"F": "-c*cross(w, q)"}])
        >>> s.driven, s.inputs.names, [f.label for f in s.forces]
        (True, ('tau',), ['[forces] F1', '[[forces.body]] #1'])
        >>> s = define_system(name="ions", bodies=3, parameters={"k": 1.0}, diagonal="1",
        ...                   data={"c": [1, -1, 2]},
        ...                   pair_terms=[{"V": "k*ci*cj/norm(qi - qj)", "pairs": "all"}])
        >>> s.terms[0].body_data
        (TermData(name='c', width=1, values=(1.0, -1.0, 2.0)),)
    """
    params = _parameters(parameters, origin)
    n = _bodies(bodies, origin)
    defaults = _inputs(inputs, params, origin)
    names = [*params, *defaults]
    shared = body_data(data, n, params, origin)
    for d in shared:
        if d.name in defaults:
            raise SpecError(f"{origin}: [data] {d.name}: the name {d.name!r} is also an input")
    matrix = _any_inertia(
        inertia, diagonal, max_index, scale, inertia_data, n, params, origin, shared
    )
    general = sp.Integer(0) if potential is None else _potential(potential, n, names, origin)
    terms = [
        *_terms(body_terms, TermKind.BODY, n, params, origin, list(defaults), shared),
        *_terms(pair_terms, TermKind.PAIR, n, params, origin, list(defaults), shared),
    ]
    drive = _forces(forces, force_terms, n, params, list(defaults), origin, force_pairs, shared)
    if potential is None and not terms:
        raise SpecError(
            f"{origin}: [potential] V: missing (give V, or terms [[potential.body]] / "
            "[[potential.pair]])"
        )
    return System.create(
        name=name,
        n=n,
        parameters=params,
        inertia=matrix,
        potential=general,
        q0=_initial(initial_q, "q", n, params, origin),
        omega0=_initial(initial_omega, "omega", n, params, origin),
        run=_run_settings(run, origin, n, list(params)),
        origin=origin,
        terms=terms,
        inertia_solver=_solver(inertia_solver, origin),
        inputs=defaults,
        forces=drive,
    )


def _any_inertia(
    inertia: Any,
    diagonal: Any,
    max_index: Any,
    scale: Any,
    data: Any,
    n: int,
    params: Mapping[str, float],
    origin: str,
    shared: tuple[TermData, ...] = (),
) -> Any:
    """M as a matrix (`M`, or `diagonal` as a list) or per body (`chain_inertia`, which also
    sees the scalar arrays of [data])."""
    per_body = isinstance(diagonal, (str, sp.Expr)) or any(
        v is not None for v in (max_index, scale, data)
    )
    if not per_body:
        return _inertia(inertia, diagonal, n, list(params), origin)
    where = f"{origin}: [inertia]"
    if inertia is not None:
        raise SpecError(f"{where}: give either 'M' or the per-body 'diagonal' (not both)")
    if not isinstance(diagonal, (str, sp.Expr)):
        raise SpecError(
            f"{where} diagonal: with max_index, scale or data, give the diagonal as one "
            f"expression per body (in i, n, the parameters and [inertia.data]), got {diagonal!r}"
        )
    scalars = scalar_data(shared, (diagonal, max_index, scale), where)
    return chain_inertia(diagonal, max_index, scale, data, n, params, origin, scalars)


def _solver(value: Any, origin: str) -> str:
    if not isinstance(value, str) or value not in INERTIA_SOLVERS:
        raise SpecError(
            f"{origin}: [inertia] solver: expected one of {', '.join(INERTIA_SOLVERS)}, "
            f"got {value!r}"
        )
    return value


# ====================================================================== TOML files
_TOP_KEYS = (
    "name",
    "bodies",
    "parameters",
    "inputs",
    "inertia",
    "potential",
    "forces",
    "initial",
    "run",
    "data",
)
_TABLE_KEYS = {
    "parameters": None,
    "data": None,
    "inputs": None,
    "forces": None,
    "inertia": ("M", "diagonal", "max_index", "scale", "data", "solver"),
    "potential": ("V", "body", "pair"),
    "initial": ("q", "omega"),
    "run": ("h", "T", "method", "rtol", "atol", "g"),
}


def load_spec(path: str | Path) -> System:
    """Read a TOML spec file and return its validated System (raises SpecError).

    Example:
        >>> from importlib.resources import files, as_file
        >>> with as_file(files("s2gen.systems.examples") / "double_pendulum.toml") as p:
        ...     load_spec(p).n
        2
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(f"{path}: no such spec file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: cannot read the spec file ({exc})") from None
    return load_spec_text(text, origin=str(path), folder=path.parent)


def load_spec_text(
    text: str, *, origin: str = "<string>", folder: str | Path | None = None
) -> System:
    """Parse TOML spec text; `origin` names it in error messages (raises SpecError).
    `folder` is where relative file names (``c = { file = "c.npy" }`` in [data],
    [inertia.data] or a term's data, ``pairs = { file = "bonds.csv" }``, see
    `s2gen.spec.files`) are found; without it they are an error.

    Example:
        >>> load_spec_text('name = "p"\\nbodies = 1\\n[parameters]\\nm = 2.0\\n'
        ...                '[inertia]\\ndiagonal = ["m"]\\n[potential]\\nV = "q1[2]"\\n').inertia
        Matrix([[m]])
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{origin}: TOML syntax error: {exc}") from None
    _check_keys(data, _TOP_KEYS, f"{origin}: top level")
    for key in ("name", "bodies", "inertia", "potential"):
        if key not in data:
            raise SpecError(f"{origin}: missing required key {shown(key)}")
    tables = {key: _table(data, key, origin) for key in _TABLE_KEYS}
    where = None if folder is None else Path(folder)
    tables["data"] = read_data_files(tables["data"], data["bodies"], where, origin, "[data]")
    inertia_data = read_data_files(
        tables["inertia"].get("data"), data["bodies"], where, origin, "[inertia] data."
    )
    potential, forces = tables["potential"], tables["forces"]
    for table, name in ((potential, "potential"), (forces, "forces")):
        for key, arity, select in (("body", 1, "bodies"), ("pair", 2, "pairs")):
            if key in table:  # member lists and term data that name files
                label = f"[[{name}.{key}]]"
                table[key] = read_term_files(table[key], arity, where, origin, label, select)
    if not {"V", "body", "pair"} & set(potential):
        raise SpecError(
            f"{origin}: [potential]: missing required key 'V' (required unless terms "
            "[[potential.body]] or [[potential.pair]] are given)"
        )
    system = define_system(
        name=data["name"],
        bodies=data["bodies"],
        parameters=tables["parameters"],
        potential=potential.get("V"),
        inertia=tables["inertia"].get("M"),
        diagonal=tables["inertia"].get("diagonal"),
        max_index=tables["inertia"].get("max_index"),
        scale=tables["inertia"].get("scale"),
        inertia_data=inertia_data,
        inertia_solver=tables["inertia"].get("solver", "auto"),
        initial_q=tables["initial"].get("q"),
        initial_omega=tables["initial"].get("omega"),
        run=tables["run"] or None,
        origin=origin,
        body_terms=potential.get("body"),
        pair_terms=potential.get("pair"),
        inputs=tables["inputs"] or None,
        forces={k: v for k, v in tables["forces"].items() if k not in ("body", "pair")} or None,
        force_terms=tables["forces"].get("body"),
        force_pairs=tables["forces"].get("pair"),
        data=tables["data"] or None,
    )
    folder_name = "" if where is None else str(where.resolve())
    return dataclasses.replace(system, source=text, source_folder=folder_name)


def _table(data: Mapping[str, Any], key: str, origin: str) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        raise SpecError(f"{origin}: {shown(key)} must be a table [{key}], got {shown(table)}")
    allowed = _TABLE_KEYS[key]
    if allowed is not None:
        _check_keys(table, allowed, f"{origin}: [{key}]")
    return table
