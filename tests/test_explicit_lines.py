"""The explicit VI's buffers start on 64-byte lines whatever the caller's workspace alignment:
the layout keeps every buffer a whole number of lines with 7 doubles to spare, and the emitted
integrate gives the reference's trajectory from a workspace at each of the 8 offsets within a
line, without writing past NAME_WORK_SIZE doubles."""

from __future__ import annotations

import numpy as np

from s2gen.passes import lower_system
from s2gen.runtime import Options, get_backend, simulate
from s2gen.spec import define_system

N = 9  # 27 doubles per component-major copy: not a whole number of lines
RNG = np.random.default_rng(5)
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.5, size=(N, 3)))


def _system() -> object:
    return define_system(
        name="lines",
        bodies=N,
        parameters={"k": 0.4},
        diagonal="1 + i/10",
        pair_terms=[{"V": "k/norm(qi - qj)", "pairs": "all"}],
        body_terms=[{"V": "-q[2]"}],
        initial_q=Q0,
        initial_omega=W0,
    )


def test_explicit_layout_is_whole_lines_with_slack() -> None:
    module = lower_system(_system())  # type: ignore[arg-type]
    (explicit,) = [lay for lay in module.layouts if lay.name == "explicit"]
    assert all(b.offset % 8 == 0 and b.size % 8 == 0 for b in explicit.buffers if b.name != "slack")
    assert explicit.buffers[-1].name == "slack" and explicit.buffers[-1].size == 7
    assert explicit.buffers[0].size >= 3 * N


def test_misaligned_workspace_gives_the_reference_trajectory() -> None:
    system = _system()
    backend = get_backend(system, "c")  # type: ignore[arg-type]
    size = backend.work.size
    p = np.array(system.parameter_values)  # type: ignore[attr-defined]
    truth = simulate(system, "vi", "reference", h=0.01, T=0.3, energy=False)  # type: ignore[arg-type]
    runs = []
    for offset in range(8):
        block = np.full(size + 16, 7.25)
        backend.work = block[offset : offset + size]
        status, q, w, _, _ = backend.integrate(
            "vi", 0.01, 30, Q0, W0, p, Options(), with_energy=False
        )
        assert status == 0
        assert np.all(block[offset + size :] == 7.25), offset  # nothing past the workspace
        assert np.max(np.abs(q - truth.q)) < 1e-12, offset
        assert np.max(np.abs(w - truth.omega)) < 1e-12, offset
        runs.append(q)
    assert all(np.array_equal(runs[0], r) for r in runs)
