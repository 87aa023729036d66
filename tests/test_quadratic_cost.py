"""The cost model that decides whether quadratic terms go into the constant matrix K.

The counts are checked against closed forms (a dense product of order N costs N^2
multiplications and N^2 additions; a full 3 x 3 bilinear coupling costs two 3 x 3
matrix-vector products per pair), and the pass's choice on small made-up systems against the
reason the model gives: a bilinear coupling of every listed pair of a few bodies takes K (its
gathered loop costs more than the matrix), the same coupling along a chain keeps its loop
(far fewer members than K has entries), and so does the coupling of every listed pair of many
bodies (K no longer fits a last-level cache, and streaming it costs more than the loop). Where K is
taken, the emitted C and NumPy follow the reference integrator, and K starts on a 64-byte
boundary whatever the alignment of the caller's workspace.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from s2gen import generate
from s2gen.equations.assemble import sphere_module
from s2gen.passes import lower_system
from s2gen.passes.cost import LANES, PIPES, Cost, bandwidth, loop_cost, matrix_cost
from s2gen.passes.quadratic import costs, quadratic_pass
from s2gen.runtime import simulate
from s2gen.spec import define_system
from s2gen.system import System
from s2gen.systems import builtin

#: A bilinear coupling through a full 3 x 3 block (9 coefficients, like two dipoles).
COUPLING = (
    "k*(dot(qi, qj) + 2*qi[0]*qj[1] - qi[1]*qj[2] + 3*qi[2]*qj[0]"
    " + qi[0]*qj[2] - 2*qi[1]*qj[0] + qi[2]*qj[1])"
)
FULL = [(r, 3 + c) for r in range(3) for c in range(3)]


def coupled(n: int, pairs: str | list[list[int]]) -> System:
    rng = np.random.default_rng(5)
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = 0.5 * rng.normal(size=(n, 3))
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    return define_system(
        name=f"coupled{n}",
        bodies=n,
        parameters={"k": 0.05},
        diagonal="1",
        pair_terms=[{"V": COUPLING, "pairs": pairs}],
        initial_q=q.tolist(),
        initial_omega=w.tolist(),
        run={"h": 0.01, "T": 0.5},
    )


def listed(n: int) -> list[list[int]]:
    return [[i, j] for i in range(1, n + 1) for j in range(i + 1, n + 1)]


def test_the_matrix_costs_a_dense_product() -> None:
    """Order N: N^2 multiplications and N^2 additions, N more for b; 8 (N^2 + 3N) bytes."""
    for order in (3, 48, 300):
        c = matrix_cost(order)
        assert (c.ops, c.bytes, c.lanes) == (2 * order**2 + order, 8 * (order**2 + 3 * order), 4)


def test_a_full_coupling_costs_two_small_products_and_a_scatter_per_pair() -> None:
    """B x_j and B^T x_i: 2 x (9 multiplications + 6 additions), and 6 additions into g."""
    c = loop_cost(10, FULL, 2)
    assert c.ops == 10 * (2 * (9 + 6) + 6)
    assert c.bytes == 10 * (8 * 9 + 4 * 2)
    assert c.lanes == 1 and loop_cost(10, FULL, 2, contiguous=True).lanes == LANES


def test_cycles_are_the_larger_of_compute_and_memory() -> None:
    compute = Cost(ops=8000, bytes=64, lanes=LANES)
    assert compute.cycles == 8000 / (PIPES * LANES)
    memory = Cost(ops=10, bytes=4 * 1024 * 1024, lanes=LANES)
    assert memory.cycles == 4 * 1024 * 1024 / bandwidth(4 * 1024 * 1024)
    assert bandwidth(1024) > bandwidth(512 * 1024) > bandwidth(8 * 1024 * 1024)


@pytest.fixture(scope="module")
def few() -> System:
    return coupled(8, listed(8))


def test_every_listed_pair_of_few_bodies_takes_the_matrix(few: System) -> None:
    """8 bodies, 28 gathered pairs of 36 operations: 504 cycles against K's 24 x 24 in 162."""
    k, loops = costs(sphere_module(few))
    assert [i for i, _ in loops] == [0]
    assert loops[0][1].cycles == 28 * 36 / 2 and k.cycles == matrix_cost(24).cycles
    assert k.cycles < loops[0][1].cycles
    assert quadratic_pass(sphere_module(few)).quadratic == 24


def test_a_chain_keeps_its_loop() -> None:
    """The same coupling along a chain of 8: 7 pairs cost 126 cycles, fewer than K's 162 (its
    5 KB streamed at 32 bytes per cycle; its 1,176 operations take 147)."""
    module = sphere_module(coupled(8, "chain"))
    k, loops = costs(module)
    assert loops[0][1].cycles == 7 * 36 / 2 and k.cycles == 8 * (24**2 + 72) / 32
    assert loops[0][1].cycles < k.cycles
    lowered = quadratic_pass(module)
    assert lowered.quadratic == 0 and not any(t.quadratic for t in lowered.terms)


def test_every_listed_pair_of_many_bodies_keeps_its_loop() -> None:
    """400 bodies: K (1,200 x 1,200, 11.5 MB) streams from L3 at 12 bytes per cycle and still
    costs less than the 79,800 gathered pairs; 700 bodies: K (35 MB) streams from memory at 4
    bytes per cycle and costs more than the 244,650 pairs."""
    module = sphere_module(coupled(400, listed(400)))
    k, loops = costs(module)
    assert 1024 * 1024 < k.bytes < 32 * 1024 * 1024 and k.cycles == k.bytes / 12
    assert k.cycles < loops[0][1].cycles == 79800 * 36 / 2
    module = sphere_module(coupled(700, listed(700)))
    k, loops = costs(module)
    assert k.bytes > 32 * 1024 * 1024 and k.cycles == k.bytes / 4
    assert loops[0][1].cycles == 244650 * 36 / 2 < k.cycles
    assert quadratic_pass(module).quadratic == 0


@pytest.mark.parametrize("method", ["vi", "rk4"])
def test_the_matrix_follows_the_reference(few: System, method: str) -> None:
    """With K (built from the coefficients), the emitted C and NumPy follow the reference
    integrator, which evaluates the coupling pair by pair."""
    assert lower_system(few).quadratic == 24
    truth = simulate(few, method, "reference", h=0.01, T=0.5, energy=False)
    for backend in ("c", "numpy"):
        run = simulate(few, method, backend, h=0.01, T=0.5, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-11, backend


@pytest.mark.parametrize("method", ["vi", "rk4"])
def test_a_linear_part_is_added_and_its_absence_skips_b(few: System, method: str) -> None:
    """A quadratic term with a linear part (a field on each body of the pair) puts it in b,
    which the products add; the emitted C and NumPy follow the reference, which evaluates the
    terms pair by pair. The same coupling without a linear part leaves b zero, and the emitted
    products do not read it."""
    field = define_system(
        name="coupled8b",
        bodies=8,
        parameters={"k": 0.05, "f": 0.3},
        diagonal="1",
        pair_terms=[{"V": COUPLING + " + f*(qi[2] - 2*qj[0])", "pairs": listed(8)}],
        initial_q=few.q0.tolist(),
        initial_omega=few.omega0.tolist(),
        run={"h": 0.01, "T": 0.5},
    )
    module = lower_system(field)
    assert module.quadratic == 24
    assert any(c < 0 <= r for t in module.terms for _, r, c in t.quadratic)
    assert not any(c < 0 <= r for t in lower_system(few).terms for _, r, c in t.quadratic)
    truth = simulate(field, method, "reference", h=0.01, T=0.5, energy=False)
    for backend in ("c", "numpy"):
        run = simulate(field, method, backend, h=0.01, T=0.5, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-11, backend
    with_b, without_b = generate(field, "c")["coupled8b.c"], generate(few, "c")["coupled8.c"]
    assert "acc[r] + bu[r]" in with_b and "bu[" not in without_b


ALIGNED_DRIVER = r"""
#include "@N@.c" /* the static context too: where K starts */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(void)
{
    double p[@U@_NPARAMS > 0 ? @U@_NPARAMS : 1], q0[@U@_NSTATE], w0[@U@_NSTATE];
    double *first = NULL;
    int off, bad = 0;
    long k;
    @N@_default_params(p);
    @N@_initial_state(q0, w0);
    for (off = 0; off < 8; ++off) {
        /* the workspace ends exactly at WORK_SIZE doubles, from 8 starting alignments */
        double *raw = (double *)malloc((@U@_WORK_SIZE + off) * sizeof(double));
        double *work = raw + off;
        double *q = (double *)malloc((@STEPS@ + 1) * @U@_NSTATE * sizeof(double));
        double *w = (double *)malloc((@STEPS@ + 1) * @U@_NSTATE * sizeof(double));
        @N@_ctx cx;
        @N@_ctx_init(&cx, p, work);
        bad |= (uintptr_t)cx.kq % 64 != 0 || cx.kq + @U@_N3 * @U@_N3 > cx.kb;
        bad |= @N@_integrate(p, NULL, @U@_METHOD_VI, @H@, @STEPS@, q0, w0, q, w, NULL, work,
                NULL) != @U@_OK;
        if (!first) {
            first = (double *)malloc(@U@_NSTATE * sizeof(double));
            memcpy(first, q + @STEPS@ * @U@_NSTATE, @U@_NSTATE * sizeof(double));
            for (k = 0; k < @U@_NSTATE; ++k) printf("%.17g\n", first[k]);
        }
        bad |= memcmp(first, q + @STEPS@ * @U@_NSTATE, @U@_NSTATE * sizeof(double)) != 0;
        free(raw);
        free(q);
        free(w);
    }
    free(first);
    return bad;
}
"""


@pytest.mark.parametrize("name", ["dipoles", "coupled8"])
def test_the_matrix_starts_on_a_cache_line_whatever_the_workspace(
    few: System, name: str, tmp_path: Path
) -> None:
    """From each of 8 alignments of a workspace of exactly WORK_SIZE doubles (under
    AddressSanitizer), K starts on a 64-byte boundary before b, and the VI gives the same state
    bit for bit, the reference integrator's to 1e-10."""
    system = builtin("dipoles") if name == "dipoles" else few
    steps, h = 200, 1e-3
    for fname, text in generate(system, "c").items():
        (tmp_path / fname).write_text(text)
    source = ALIGNED_DRIVER.replace("@N@", system.name).replace("@U@", system.name.upper())
    source = source.replace("@STEPS@", str(steps)).replace("@H@", repr(h))
    (tmp_path / "driver.c").write_text(source)
    exe = tmp_path / "driver"
    flags = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    cmd = ["gcc", "-std=c99", "-O2", "-g", *flags, "-o", str(exe), "driver.c", "-lm"]
    built = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, check=False)
    assert built.returncode == 0, built.stderr[:3000]
    run = subprocess.run([str(exe)], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[:3000]
    q = np.array(run.stdout.split(), dtype=float).reshape(-1, 3)
    truth = simulate(system, "vi", "reference", h=h, T=steps * h, energy=False)
    assert np.max(np.abs(q - truth.q[-1])) < 1e-10
