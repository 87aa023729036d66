"""Validation of the inertia M: a given matrix, or per-body expressions (a chain).

Input: M as a SymPy matrix or a `ChainInertia`, the number of bodies, the parameter symbols
and values, and the location for messages. Output: the matrix as an immutable sparse matrix
(or nothing for a chain), or a `SpecError`: M must be constant (parameters only), symmetric,
finite and positive definite at the parameter values.
"""

from __future__ import annotations

import warnings

import numpy as np
import sympy as sp

from s2gen.errors import SpecError, SpecWarning
from s2gen.inertia import INDEX, ChainInertia, chain_cholesky_pivots, chain_structure

__all__: list[str] = []


def _validate_matrix(
    inertia: sp.MatrixBase,
    n: int,
    psyms: set[sp.Symbol],
    subs: dict[sp.Symbol, float],
    where: str,
) -> sp.ImmutableSparseMatrix:
    """A given M: shape, constant entries (parameters only), symmetric, positive definite."""
    # SymPy's constructor sorts every entry (13 s for 10^5 bodies): keep a given one as is
    M = (
        inertia
        if isinstance(inertia, sp.ImmutableSparseMatrix)
        else sp.ImmutableSparseMatrix(inertia)
    )
    if M.shape != (n, n):
        raise SpecError(f"{where}: [inertia] M: expected a {n}x{n} matrix, got {M.shape}")
    entries = {key: sp.sympify(v) for key, v in M.todok().items()}
    checked: set[sp.Expr] = set()  # most entries repeat (uniform masses): check each once
    for (r, c), entry in sorted(entries.items()):
        if entry in checked:
            continue
        checked.add(entry)
        extra = entry.free_symbols - psyms
        if extra:
            bad = ", ".join(sorted(str(s) for s in extra))
            raise SpecError(
                f"{where}: [inertia] M[{r + 1}][{c + 1}]: depends on {bad}, "
                "but the inertia must be constant (parameters only)"
            )
    for (r, c), entry in sorted(entries.items()):
        other = entries.get((c, r), sp.Integer(0))
        upper_or_lone = r < c or (r > c and (c, r) not in entries)
        if upper_or_lone and entry != other and sp.simplify(entry - other) != 0:
            lo, hi = min(r, c), max(r, c)
            raise SpecError(
                f"{where}: [inertia] M is not symmetric: M[{lo + 1}][{hi + 1}] = "
                f"{M[lo, hi]} but M[{hi + 1}][{lo + 1}] = {M[hi, lo]}"
            )
    _check_positive_definite(entries, n, subs, where)
    return M


def _validate_chain(
    chain: ChainInertia,
    n: int,
    psyms: set[sp.Symbol],
    subs: dict[sp.Symbol, float],
    where: str,
) -> None:
    """Per-body inertia: its symbols, its data (one finite number per body), finite values
    and positive definiteness (an O(n) Cholesky; `s2gen.inertia.chain_cholesky_pivots`)."""
    names = [d.name for d in chain.data]
    for d in chain.data:
        if d.width != 1 or len(d.values) != n:
            raise SpecError(
                f"{where}: [inertia.data] {d.name}: expected {n} numbers (one per body), got "
                f"{len(d.values) / max(d.width, 1):g} entries of width {d.width}"
            )
        if not all(np.isfinite(d.values)):
            raise SpecError(f"{where}: [inertia.data] {d.name}: contains a non-finite value")
    clash = sorted(({p.name for p in psyms} | {INDEX.name}) & set(names))
    if clash or len(set(names)) != len(names):
        bad = clash[0] if clash else next(x for x in names if names.count(x) > 1)
        raise SpecError(
            f"{where}: [inertia.data] {bad}: the name is also a parameter, the body index i "
            "or another datum"
        )
    allowed = psyms | set(chain.data_symbols()) | {INDEX}
    for key, expr in (
        ("diagonal", chain.diagonal),
        ("scale", chain.scale),
        ("max_index", chain.max_index),
    ):
        if not isinstance(expr, sp.Expr):
            raise SpecError(f"{where}: [inertia] {key}: must be a scalar expression")
        extra = expr.free_symbols - allowed
        if extra:
            bad = ", ".join(sorted(str(s) for s in extra))
            raise SpecError(
                f"{where}: [inertia] {key}: depends on {bad}, which is not a parameter, "
                "a datum of [inertia.data] or the body index i"
            )
    try:
        d, a, c = chain.numeric(n, subs)
    except (TypeError, ValueError, ZeroDivisionError) as exc:
        raise SpecError(f"{where}: [inertia] cannot evaluate M per body ({exc})") from None
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(a)) and np.all(np.isfinite(c))):
        raise SpecError(f"{where}: [inertia] M is not finite at the parameter values")
    pivots = chain_cholesky_pivots(d, a, c)
    if not np.all(pivots > 0.0):
        k = int(np.argmin(np.nan_to_num(pivots, nan=np.inf) > 0.0))
        raise SpecError(
            f"{where}: [inertia] M is not positive definite at the parameter values "
            f"(Cholesky pivot {k + 1} is {pivots[k]:.6g})"
        )
    coupled = not (n == 1 or chain.max_index == 0 or chain.scale == 0)
    if coupled and not chain_structure(chain, n, subs):
        warnings.warn(
            f"{where}: [inertia]: the O(n) solvers need scale != 0 at every body and "
            "max_index_k != max_index_k+1 (max_index_n != 0); M is treated as a general "
            "matrix (n^2 entries, dense solves)",
            SpecWarning,
            stacklevel=4,
        )


def _check_positive_definite(
    entries: dict[tuple[int, int], sp.Expr], n: int, subs: dict[sp.Symbol, float], where: str
) -> None:
    """M must be real, finite and positive definite at the parameter values."""
    values: dict[tuple[int, int], float] = {}
    cache: dict[sp.Expr, float] = {}
    for key, entry in entries.items():
        if entry not in cache:
            try:
                cache[entry] = float(sp.sympify(entry.xreplace(subs)).evalf())
            except (TypeError, ValueError):
                msg = f"{where}: [inertia] M is not real at the parameter values"
                raise SpecError(msg) from None
        values[key] = cache[entry]
    if not all(np.isfinite(v) for v in values.values()):
        raise SpecError(f"{where}: [inertia] M is not finite at the parameter values")
    if all(r == c for r, c in values):
        diag = np.array([values.get((i, i), 0.0) for i in range(n)])
        smallest = float(diag.min())
    else:
        dense = np.zeros((n, n))
        for (r, c), v in values.items():
            dense[r, c] = v
        smallest = float(np.linalg.eigvalsh(dense)[0])
    if smallest <= 0.0:
        raise SpecError(
            f"{where}: [inertia] M is not positive definite at the parameter values "
            f"(smallest eigenvalue {smallest:.6g})"
        )
