"""Reference tables read from the package's own tables at build time.

``.. s2gen-spec-keys::`` lists every key a spec may hold, in the order and with the names the
spec reader checks (`s2gen.spec`'s key tables, the term kinds, `RunSettings`), each with its
meaning; a key the reader accepts and this page does not describe fails the build.
``.. s2gen-methods::`` is the method table (`s2gen.METHODS`). ``.. s2gen-builtins::`` lists
the built-in systems with their options and defaults (`s2gen.systems`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from s2gen.methods import METHODS
from s2gen.system import INERTIA_SOLVERS, MAX_BODIES

#: What each key means, by (table, key); the keys themselves come from the spec reader.
MEANINGS: dict[tuple[str, str], str] = {
    ("", "name"): "a C identifier of at most 64 characters, not starting with ``_``; prefixes "
    "every emitted function",
    ("", "bodies"): f"the number n of bodies, a positive integer (at most {MAX_BODIES:,})",
    ("", "parameters"): "a table ``name = number``; the parameters the expressions may use "
    "(the emitted code takes them as an array, defaults from here)",
    ("", "inputs"): "a table ``name = default``; the caller's inputs, held over each step "
    "(driven systems; potentials and forces may use them)",
    ("", "inertia"): "the constant inertia matrix M (its keys below)",
    ("", "potential"): "the potential V (its keys below)",
    ("", "forces"): "generalized forces F_i conjugate to q_i (its keys below; optional)",
    ("", "initial"): "the initial state (its keys below; optional)",
    ("", "run"): "default run settings (its keys below; optional)",
    ("", "data"): "a table ``name = list``: per-body arrays, one number or one 3-vector per "
    "body, read by every term (``c`` in body terms, ``ci`` and ``cj`` in pair terms) and by the "
    "per-body inertia (optional); an entry may name a file instead of listing the values: "
    '``c = { file = "c.npy" }`` (``.npy``, ``.txt`` or ``.csv``, one row per body, relative to '
    "the spec's folder)",
    ("inertia", "M"): "the n × n entries of M, numbers or expressions in the parameters",
    ("inertia", "diagonal"): "the diagonal of M: a list of n entries, or one expression per "
    "body in ``i`` (1…n), ``n``, the parameters and the data",
    ("inertia", "max_index"): "c_k of the off-diagonal entries M_ij = scale_i scale_j "
    "c_max(i,j) (a chain); optional",
    ("inertia", "scale"): "a_i of the same (optional, default 1)",
    ("inertia", "data"): "per-body data for these expressions: one number per body (or a "
    '``{ file = "..." }`` entry, as in ``[data]``)',
    ("inertia", "solver"): "how M's linear systems are solved: "
    + ", ".join(f'``"{s}"``' for s in INERTIA_SOLVERS)
    + " (default ``auto``: the structure's solver where an operation count says it is cheaper)",
    ("potential", "V"): "the general part of V, an expression in ``q1``…``qn``, time ``t`` and "
    "the inputs (optional when terms are given)",
    ("potential", "body"): "one-body terms: an array of tables ``[[potential.body]]`` (below)",
    ("potential", "pair"): "pair terms: an array of tables ``[[potential.pair]]`` (below)",
    ("initial", "q"): "n unit 3-vectors (entries numbers or expressions); within 1e-3 of unit "
    "length, normalized with a warning",
    ("initial", "omega"): "n angular velocities, each perpendicular to its q_i (projected "
    "with a warning when nearly so)",
    ("run", "h"): "the step size (positive)",
    ("run", "T"): "the final time (positive, a whole number of steps)",
    ("run", "method"): "the default method: " + ", ".join(f"``{m.name}``" for m in METHODS),
    ("run", "rtol"): "relative tolerance of the adaptive methods",
    ("run", "atol"): "absolute tolerance of the adaptive methods",
    ("run", "g"): "the monitor R(q) of the time-transformed methods (``vi-adaptive``, ...): an "
    "expression in ``q1``…``qn`` and the parameters, positive, large where the bodies move "
    "fast (default: derived from the pair terms)",
    ("forces", "F1"): "``F1`` … ``Fn``: the force on body i, a 3-vector in ``q1``…``qn``, "
    "``w1``…``wn`` (angular velocities), ``t``, the inputs and the parameters",
    ("forces", "body"): "one-body forces: an array of tables ``[[forces.body]]`` with ``F`` (a "
    "3-vector in the body's own ``q`` and ``w``), ``bodies`` and ``data`` as for "
    "``[[potential.body]]``",
    ("term", "V"): "the term's expression, in its own vectors",
    ("term", "data"): "per-member data: a table of lists, one entry per member (numbers or "
    "3-vectors)",
    ("term", "cutoff"): "pair terms only: only pairs with chord distance ``|qi - qj|`` below "
    "it count (cell lists keep the cost O(n))",
}


def _row(cells: tuple[str, ...]) -> list[str]:
    return [f"   * - {cells[0]}", *(f"     - {c}" for c in cells[1:])]


def _list_table(title: str, header: tuple[str, ...], rows: Sequence[tuple[str, ...]]) -> str:
    lines = [f".. list-table:: {title}", "   :header-rows: 1", ""]
    for cells in (header, *rows):
        lines += _row(cells)
    return "\n".join(lines) + "\n"


def _meaning(table: str, key: str) -> str:
    found = MEANINGS.get((table, key))
    if found is None:
        raise KeyError(f"the spec key {table}.{key} has no description in docs/_ext")
    return found


def spec_keys_rst() -> str:
    """The table of every spec key (the reader's own key tables), as reStructuredText.

    Example:
        >>> "max_index" in spec_keys_rst()
        True
    """
    from s2gen import spec
    from s2gen.terms import TermKind, spellings

    rows = [(f"``{k}``", "top level", _meaning("", k)) for k in spec._TOP_KEYS]
    for table, keys in spec._TABLE_KEYS.items():
        for key in keys or ():
            rows.append((f"``{key}``", f"``[{table}]``", _meaning(table, key)))
    for kind in TermKind:
        roles = ", ".join(f"``{r}``" for r in kind.roles)
        default = f" (default ``{kind.default}``)" if kind.default else " (required)"
        keys = ("V", kind.select_key, "data") + (("cutoff",) if kind is TermKind.PAIR else ())
        named = ", ".join(f'"{word}"' for word in spellings(kind, named=True))
        for key in keys:
            if key == kind.select_key:
                text = f"the members: {named} or a list of {kind.listing}{default}"
            else:
                text = _meaning("term", key)
                if key == "V":
                    text += f" ({roles})"
            rows.append((f"``{key}``", f"``{kind.table}``", text))
    rows += [
        ("``F1`` … ``Fn``", "``[forces]``", _meaning("forces", "F1")),
        ("``body``", "``[forces]``", _meaning("forces", "body")),
    ]
    return _list_table("Spec keys", ("key", "table", "meaning"), rows)


def methods_rst() -> str:
    """The method table, as reStructuredText.

    Example:
        >>> "dop853" in methods_rst()
        True
    """
    rows = [
        (
            f"``{m.name}``",
            str(m.order),
            "adaptive" if m.evals == 0 else str(m.evals),
            "yes" if m.implicit else "no",
            ", ".join(m.backends),
            m.summary.replace("|", "\\|"),
        )
        for m in METHODS
    ]
    header = (
        "method",
        "order",
        "gradients per step",
        "implicit when M is coupled",
        "backends",
        "what it is",
    )
    return _list_table("Methods", header, rows)


def builtins_rst() -> str:
    """The built-in systems with their options, as reStructuredText.

    Example:
        >>> "elastic_rod" in builtins_rst()
        True
    """
    from s2gen.systems import builtin_names, builtin_options

    rows = []
    for name in builtin_names():
        opts = ", ".join(f"``{o.name}={o.default}``" for o in builtin_options(name)) or "–"
        rows.append((f"``{name}``", opts))
    return _list_table("Built-in systems", ("name", "options (defaults)"), rows)


def setup(app: Any) -> dict[str, Any]:
    """Register the table directives (Sphinx is imported here only, so that the tests can
    call the functions above without it)."""
    from sphinx.util.docutils import SphinxDirective

    def directive(make: Any) -> type[SphinxDirective]:
        class Table(SphinxDirective):
            def run(self) -> list[Any]:
                return self.parse_text_to_nodes(make())

        return Table

    app.add_directive("s2gen-spec-keys", directive(spec_keys_rst))
    app.add_directive("s2gen-methods", directive(methods_rst))
    app.add_directive("s2gen-builtins", directive(builtins_rst))
    return {"parallel_read_safe": True, "parallel_write_safe": True}
