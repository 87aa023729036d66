"""Semantic validation of a system's parts, one module per part (used by `System.create`).

Input: the parts of a system as the front doors give them (names, SymPy expressions and
matrices, `Term`s, numbers). Output: nothing, or the part normalized (the inertia matrix, the
initial state); a `SpecError` naming the origin, the key and the offending item otherwise.
`names` checks the system name and the reality of expressions, `terms` the structured terms,
`inertia` M (a matrix or per-body expressions) and `initial` the initial state.
"""
