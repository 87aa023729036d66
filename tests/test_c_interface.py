"""The emitted C as a library: C++ compilation, several systems in one translation unit, the
NULL rules, the output stride, the q0 check and the module's description of itself."""

from __future__ import annotations

import ctypes
import subprocess
from pathlib import Path

import numpy as np
import pytest

from s2gen.build import STRICT_FLAGS
from s2gen.emit import emit
from s2gen.methods import Status, method
from s2gen.runtime import Options, get_backend, simulate
from s2gen.runtime.c import contiguous, pointer
from s2gen.systems import builtin, resolve
from s2gen.version import __version__

DRIVER = r"""
#include <stdio.h>
#include <string.h>
#include "double_pendulum.h"
#include "four_pendula.h"

/* Integrate with everything given, then with opt, energy and stats NULL: same states. */
static int null_rules(void)
{
    double p[DOUBLE_PENDULUM_NPARAMS], work[DOUBLE_PENDULUM_WORK_SIZE];
    double q0[6] = {0.8660254037844386, 0.0, 0.5, 0.0, 0.0, 1.0};
    double w0[6] = {-0.4330127018922193, 0.0, 0.75, 0.0, 1.0, 0.0};
    double qa[6 * 11], wa[6 * 11], ea[11], qb[6 * 11], wb[6 * 11];
    double_pendulum_options opt;
    double_pendulum_stats st;
    int a, b;
    double_pendulum_default_params(p);
    double_pendulum_default_options(&opt);
    a = double_pendulum_integrate(p, &opt, DOUBLE_PENDULUM_METHOD_VI, 0.01, 10, q0, w0, qa, wa, ea,
            work, &st);
    b = double_pendulum_integrate(p, NULL, DOUBLE_PENDULUM_METHOD_VI, 0.01, 10, q0, w0, qb, wb,
            NULL, work, NULL);
    if (a || b || memcmp(qa, qb, sizeof qa) || memcmp(wa, wb, sizeof wa) || st.steps != 10) {
        return 1;
    }
    return double_pendulum_vi_step(p, NULL, 0.01, q0, w0, qb, wb, work, NULL);
}

int main(void)
{
    double p4[FOUR_PENDULA_NPARAMS], q[12] = {0}, g[12];
    int status = null_rules();
    four_pendula_default_params(p4);
    q[2] = q[5] = q[8] = q[11] = 1.0;
    four_pendula_gradient(p4, q, g);
    printf("%d %s %s %s %.17g\n", status, double_pendulum_param_names[0],
            four_pendula_spec_hash, double_pendulum_generator_version, g[2]);
    return status;
}
"""


def _write(tmp_path: Path, names: tuple[str, ...]) -> None:
    for name in names:
        for fname, text in emit(builtin(name), "c").items():
            (tmp_path / fname).write_text(text)


def _run(cmd: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, check=False)


def test_the_c_compiles_as_cpp(tmp_path: Path) -> None:
    """The emitted .c is also valid C++ (the restrict spelling, casts, names), the structured
    solvers' (rope: max-index inertia) included."""
    _write(tmp_path, ("double_pendulum", "dipoles", "rope"))
    for name in ("double_pendulum", "dipoles", "rope"):
        cmd = ["g++", "-x", "c++", "-std=c++11", "-Wall", "-Wextra", "-Werror", "-c", f"{name}.c"]
        proc = _run(cmd, tmp_path)
        assert proc.returncode == 0, proc.stderr[:3000]


@pytest.mark.parametrize(
    "name", ["double_pendulum", "dipoles", "four_pendula", "rope:n=10", "forced_double_pendulum"]
)
def test_batch_modules_compile_without_warnings(tmp_path: Path, name: str) -> None:
    """A module with integrate_batch() (the dense M's lanes, the quadratic terms' lanes without
    a linear part, member tables, lane by lane, a driven one) compiles under -Wall -Wextra
    -Werror: no unused variable or parameter in any of its lane layouts."""
    system = resolve(name).with_batch()
    for fname, text in emit(system, "c").items():
        (tmp_path / fname).write_text(text)
    source = f"{system.name}.c"
    proc = _run(["gcc", *STRICT_FLAGS, "-O2", "-c", source, "-o", "m.o"], tmp_path)
    assert proc.returncode == 0, proc.stderr[:3000]


def test_two_systems_in_one_translation_unit(tmp_path: Path) -> None:
    """Two systems' .c files included into one file compile (no unprefixed internal macro or
    static name collides), link with -lm and run; the NULL rules hold; the module describes
    itself (parameter names, spec hash, generator version)."""
    _write(tmp_path, ("double_pendulum", "four_pendula"))
    unity = '#include "double_pendulum.c"\n#include "four_pendula.c"\n' + DRIVER
    (tmp_path / "unity.c").write_text(unity)
    proc = _run(
        ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-o", "unity", "unity.c", "-lm"],
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[:3000]
    out = _run(["./unity"], tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    status, pname, spec_hash, version, g2 = out.stdout.split()
    four = builtin("four_pendula")
    assert (status, pname, version) == ("0", "m1", __version__)
    assert spec_hash == four.spec_hash()
    expected = get_backend(four, "reference").gradient(
        np.tile([0.0, 0.0, 1.0], (4, 1)), np.array(four.parameter_values)
    )
    assert float(g2) == pytest.approx(expected[0, 2], rel=1e-14)


@pytest.mark.parametrize(
    ("system", "methods"),
    [
        ("double_pendulum", ("vi", "vi4", "rattle", "rk4", "rk45")),
        # diagonal M: the explicit VI's driver, whose steps write a stored sample directly
        # and the others into scratch
        ("three_bodies", ("vi", "vi4")),
    ],
)
def test_the_stride_keeps_every_kth_sample_exactly(system: str, methods: tuple[str, ...]) -> None:
    """every = 7 stores samples 0, 7, 14, ... of the every = 1 run, bit for bit, for every
    method family (and as the NumPy backend computes them); energy is evaluated only where
    asked."""
    s = builtin(system)
    for name in methods:
        full = simulate(s, name, "c", h=0.01, T=0.7)
        for backend in ("c", "numpy"):
            part = simulate(s, name, backend, h=0.01, T=0.7, every=7)
            scale = 1.0 if backend == "c" else 1e-13
            np.testing.assert_allclose(part.q, full.q[::7], rtol=0, atol=0 if scale == 1 else 1e-12)
            np.testing.assert_allclose(part.energy, full.energy[::7], rtol=1e-13, atol=0)
            np.testing.assert_allclose(part.t, full.t[::7], rtol=1e-15)
        assert simulate(s, name, "c", h=0.01, T=0.7, every=7, energy=False).energy is None
    with pytest.raises(ValueError, match="every=3 must be a positive divisor of the 70 steps"):
        simulate(s, "vi", "c", h=0.01, T=0.7, every=3)


def test_a_non_unit_q0_is_refused_by_the_c_naming_the_body() -> None:
    """The emitted integrate() refuses q0_i with | |q0_i| - 1 | > unit_tol (ERR_ARGUMENT,
    stats->fail_body), and runs when the check is off."""
    s = builtin("four_pendula")
    be = get_backend(s, "c")
    lib = be.library
    q0 = s.q0.copy()
    q0[2] *= 1.1
    n = s.n
    q, w = np.zeros((11, n, 3)), np.zeros((11, n, 3))
    for tol, expected in ((1e-12, Status.ARGUMENT), (0.0, Status.OK)):
        st = lib.Stats()
        code = be._fn["integrate"](
            contiguous(np.array(s.parameter_values)),
            ctypes.byref(lib.options(Options(unit_tol=tol))),
            method("vi").code,
            0.001,
            10,
            contiguous(q0),
            contiguous(s.omega0),
            q,
            w,
            pointer(None),
            be.work,
            ctypes.byref(st),
        )
        assert code == expected
        assert st.fail_body == (2 if expected == Status.ARGUMENT else -1)


def test_the_python_api_checks_what_it_passes_on() -> None:
    """Wrong shapes, non-finite values, non-unit q0 and a wrong number of parameters are one
    clear error before anything runs, on every backend."""
    s = builtin("double_pendulum")
    bad_q = s.q0.copy()
    bad_q[1] *= 1.1
    for backend in ("c", "numpy", "reference"):
        with pytest.raises(ValueError, match="q0 of body 2 has length 1.1"):
            simulate(s, "vi", backend, h=0.01, T=0.1, q0=bad_q)
        with pytest.raises(ValueError, match=r"q0 must have shape \(2, 3\)"):
            simulate(s, "vi", backend, h=0.01, T=0.1, q0=s.q0[:1])
        with pytest.raises(ValueError, match="omega0 contains a non-finite value"):
            simulate(s, "vi", backend, h=0.01, T=0.1, omega0=s.omega0 * np.nan)
        with pytest.raises(ValueError, match="expected 5 parameter values"):
            simulate(s, "vi", backend, h=0.01, T=0.1, params=np.ones(3))
