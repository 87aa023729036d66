"""benchmarks/poincare_transform.py: the Poincare-transformed generalized RATTLE that the
benchmark compares with the time-transformed VI is what it claims to be (symmetric, of its
composition's order, on the spheres), so that its measured costs mean something."""

from __future__ import annotations

import numpy as np
from poincare_transform import Poincare  # benchmarks/ is on pytest's pythonpath


def test_step_is_reversible_and_keeps_unit_length() -> None:
    """One step forward, the momenta flipped, one step again: back at the start (a symmetric
    method), with |q_i| = 1 and the tangency q_i . p_i = 0 kept to round-off."""
    pc = Poincare("encounter_cluster")
    x = pc.q0 / np.linalg.norm(pc.q0, axis=1)[:, None]
    p = pc.m[:, None] * np.cross(pc.w0, x)

    def state(x: np.ndarray) -> dict:
        V, gV = pc._V(x)
        G, gG = pc._G(x, True)
        return {"V": V, "gV": gV, "G": G, "gG": gG}

    e0 = pc._T(p) + pc._V(x)[0]
    x1, p1, dt = pc._step(x, p, 0.2, e0, state(x))
    x2, p2, dt2 = pc._step(x1, -p1, 0.2, e0, state(x1))
    assert dt > 0 and abs(dt - dt2) <= 1e-15 * dt
    assert np.abs(x2 - x).max() < 1e-14 and np.abs(p2 + p).max() < 1e-14
    assert np.abs(np.linalg.norm(x1, axis=1) - 1).max() < 1e-15
    assert np.abs(np.einsum("ij,ij->i", x1, p1)).max() < 1e-15


def test_energy_error_falls_at_the_composition_order() -> None:
    """The energy error of the triple jump falls like eps^4 (fitted over a halving)."""
    pc = Poincare("encounter_cluster")
    e1 = pc.run(4, 0.1, 0.5).max_rel
    e2 = pc.run(4, 0.05, 0.5).max_rel
    order = np.log2(e1 / e2)
    assert 3.5 < order < 4.6, order
    assert pc.run(2, 0.05, 0.5).max_rel > 10 * e2
