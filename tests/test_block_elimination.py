"""The max-index solves' block elimination and its fallback, against the reference integrator.

The emitted C solves the coupled systems of a max-index M body by body (block elimination
with pivoting within each body's block) and falls back to the band elimination with partial
pivoting over all rows when a block's entries grow (a nearly singular block before it), a
pivot is 0 or the result is not finite. These systems make the first body's block singular,
or nearly so, while M stays positive definite and well conditioned, so the fallback must take
over; the rope and the rods (no fallback) are compared with the dense solvers in
tests/test_chains.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from s2gen.equations.structure import choose_solver
from s2gen.inertia import InertiaKind
from s2gen.runtime import simulate
from s2gen.spec import define_system
from s2gen.system import System

N = 6


def _pivoted(first: float) -> System:
    """M = C + diag(first, 1, ..., 1), C_ij = c_max(i,j), c_i = n - i + 1: positive definite
    for first >= -1 (x^T M x = (1 + first) x_1^2 + sum_k>=2 ((x_1 + .. + x_k)^2 + x_k^2)).
    In the field's solve the first block [[(M_11 - c_1) I, I], [-I, I / (c_1 - c_2)]] is
    singular exactly when M_11 = c_2, i.e. first = -1. (Only a block before the last can be:
    the blocks' determinants multiply to the system's, so a singular last block means a
    singular M.)"""
    q0 = [[np.sin(0.3 * k), 0.0, np.cos(0.3 * k)] for k in range(N)]
    w0 = [[-0.5 * np.cos(0.3 * k), 1.0 + 0.1 * k, 0.5 * np.sin(0.3 * k)] for k in range(N)]
    return define_system(
        name="pivoted",
        bodies=N,
        parameters={"k": 1.5},
        diagonal="n - i + 1 + e",
        max_index="n - i + 1",
        inertia_data={"e": [first] + [1.0] * (N - 1)},
        pair_terms=[{"V": "k*(1 - dot(qi, qj))", "pairs": "chain"}],
        initial_q=q0,
        initial_omega=w0,
        inertia_solver="structured",
    )


@pytest.mark.parametrize("first", [-1.0, -1.0 + 1e-9])
def test_singular_first_block_falls_back_and_matches_the_reference(first: float) -> None:
    """Singular (its pivot at round-off level) and nearly singular (a pivot of 1e-9, whose
    block elimination would lose about nine digits: 1e-9 in the field, 4e-5 in the VI's
    velocities when the fallback is removed; the growth test is what catches both): the C
    agrees with the reference's dense M to round-off."""
    s = _pivoted(first)
    assert choose_solver(s) is InertiaKind.MAX_INDEX
    for method in ("rk4", "vi"):
        c = simulate(s, method, "c", h=1e-3, T=0.3)
        r = simulate(s, method, "reference", h=1e-3, T=0.3)
        assert np.max(np.abs(c.q - r.q)) < 1e-11, method
        assert np.max(np.abs(c.omega - r.omega)) < 1e-11 * np.max(np.abs(r.omega)), method
        assert np.max(np.abs(c.energy - r.energy)) < 1e-11 * np.max(np.abs(r.energy)), method
