"""Every built-in's emitted C under AddressSanitizer and UndefinedBehaviorSanitizer (and, in the
slow suite, valgrind's memcheck): a driver runs every method the C backend has from the
system's own initial state, with every caller array allocated at exactly the size the header
states (trajectory (nsteps + 1) * NSTATE, energy nsteps + 1, workspace WORK_SIZE, step()'s carry
STEP_CARRY), so a write or read past any of them is reported; every fixed-step method runs again
through step() and must end in integrate()'s final state bit for bit, and initial_state() must
hand back the spec's state. Any sanitizer report fails the test; so does a failed integration, a
non-finite result or a difference.

Every closed built-in runs in the default suite (the driven ones in tests/test_driven_c.py) (about 12 s on two cores); among them the double
pendulum (coupled: Newton, linear solves) and the four pendula (diagonal, with one-body and
pair terms). Valgrind runs those two in the slow suite.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from s2gen import generate
from s2gen.methods import METHODS, Driver, Method
from s2gen.monitor import emitted_refusal
from s2gen.system import System
from s2gen.systems import builtin, builtin_names

C_METHODS = [m for m in METHODS if "c" in m.backends]


def c_methods(system: System) -> list[Method]:
    """The C methods `system`'s module runs: the time-transformed ones only with a monitor."""
    has = emitted_refusal(system) is None
    return [m for m in C_METHODS if has or m.driver is not Driver.TIME_TRANSFORMED]


SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
ENV = {
    "ASAN_OPTIONS": "halt_on_error=1:detect_leaks=1:abort_on_error=0",
    "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1",
}
REPORTS = ("AddressSanitizer", "LeakSanitizer", "runtime error:", "UndefinedBehaviorSanitizer")
#: Steps per method: a few hundred; molecular (642 bodies, all pairs) a few. A composition of
#: s substeps runs 1/s of them (at least 5 steps), so each method evaluates as many gradients.
STEPS = {"molecular": 10}
#: The systems valgrind runs (slow suite).
VALGRIND_SUITE = ("double_pendulum", "four_pendula")
#: Built-ins whose integrate() takes time and inputs (their own driver: tests/test_driven_c.py)
DRIVEN = ("forced_double_pendulum", "kapitza")

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")


def _doubles(values: object) -> str:
    import numpy as np

    return ", ".join(repr(float(v)) for v in np.asarray(values, dtype=float).ravel())


def driver_source(system: System) -> str:
    """A C program that integrates `system` with step h (argv[1]) by each method code given on
    its command line, each followed by its number of steps."""
    name, up = system.name, system.name.upper()
    return f"""#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "{name}.h"

static const double q_init[] = {{{_doubles(system.q0)}}};
static const double w_init[] = {{{_doubles(system.omega0)}}};

static double *exactly(size_t count)
{{
    double *a = malloc(count * sizeof *a);
    if (!a) {{ fprintf(stderr, "out of memory\\n"); exit(3); }}
    return a;
}}

int main(int argc, char **argv)
{{
    long nsteps, k;
    double h = atof(argv[1]);
    int i, bad = 0;
    double *p = exactly({up}_NPARAMS > 0 ? {up}_NPARAMS : 1);
    double *q0 = exactly({up}_NSTATE), *w0 = exactly({up}_NSTATE);
    {name}_options opt;
    {name}_default_params(p);
    {name}_default_options(&opt);
    memcpy(q0, q_init, sizeof q_init);
    memcpy(w0, w_init, sizeof w_init);
    for (i = 2; i + 1 < argc; i += 2) {{
        int method = atoi(argv[i]);
        size_t samples;
        nsteps = atol(argv[i + 1]);
        samples = (size_t)nsteps + 1;
        double *q = exactly(samples * {up}_NSTATE), *w = exactly(samples * {up}_NSTATE);
        double *en = exactly(samples), *work = exactly({up}_WORK_SIZE);
        {name}_stats st;
        {name}_stepper run;
        int status = {name}_integrate(p, &opt, method, h, nsteps, q0, w0, q, w, en, work, &st);
        int stepped = {name}_step_start(&run, method, 0.0);
        for (k = 0; status == {up}_OK && k < (long)(samples * {up}_NSTATE); ++k)
            if (!isfinite(q[k]) || !isfinite(w[k])) {{ bad = 1; break; }}
        if (status == {up}_OK && stepped == {up}_OK) {{
            /* the same run by step(), its carry exactly STEP_CARRY doubles: integrate()'s end */
            double *carry = exactly({up}_STEP_CARRY), *qa = exactly({up}_NSTATE);
            double *wa = exactly({up}_NSTATE), *qb = exactly({up}_NSTATE);
            double *wb = exactly({up}_NSTATE), *t;
            memcpy(qa, q0, sizeof q_init);
            memcpy(wa, w0, sizeof w_init);
            for (k = 0; stepped == {up}_OK && k < nsteps; ++k) {{
                stepped = {name}_step(p, &opt, &run, h, qa, wa, qb, wb, carry, work, NULL);
                t = qa; qa = qb; qb = t; t = wa; wa = wb; wb = t;
            }}
            bad |= stepped != {up}_OK || run.steps != nsteps
                || memcmp(qa, q + nsteps * {up}_NSTATE, sizeof q_init) != 0
                || memcmp(wa, w + nsteps * {up}_NSTATE, sizeof w_init) != 0;
            free(carry); free(qa); free(wa); free(qb); free(wb);
        }}
        printf("method %d status %d steps %ld energy %.17g step %d\\n", method, status, st.steps,
               en[status == {up}_OK ? nsteps : 0], stepped);
        bad |= status != {up}_OK;
        free(q); free(w); free(en); free(work);
    }}
    bad |= {name}_initial_state(q0, w0) != {up}_OK || memcmp(q0, q_init, sizeof q_init) != 0
        || memcmp(w0, w_init, sizeof w_init) != 0;
    free(p); free(q0); free(w0);
    return bad;
}}
"""


def build_driver(
    system: System, folder: Path, flags: list[str], edit: Callable[[str], str] = str
) -> Path:
    """The emitted C and the driver (passed through `edit`), compiled with `flags`."""
    folder.mkdir(parents=True, exist_ok=True)
    for fname, text in generate(system, "c").items():
        (folder / fname).write_text(text)
    (folder / "driver.c").write_text(edit(driver_source(system)))
    exe = folder / "driver"
    cmd = ["gcc", "-std=c99", "-g", *flags, "-o", str(exe), str(folder / "driver.c"),
           str(folder / f"{system.name}.c"), f"-I{folder}", "-lm"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    return exe


def _args(system: System) -> list[str]:
    h = system.run.h
    assert h is not None
    steps = STEPS.get(system.name, 300)
    runs = [(m.code, max(5, steps // len(m.substeps or (1.0,)))) for m in c_methods(system)]
    return [repr(h), *(str(x) for run in runs for x in run)]


def _check_output(proc: subprocess.CompletedProcess[str], tool: str, system: System) -> None:
    report = [line for line in proc.stderr.splitlines() if any(r in line for r in REPORTS)]
    assert not report, f"{tool} report:\n{proc.stderr[-4000:]}"
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout}\n{proc.stderr[-4000:]}"
    lines = proc.stdout.splitlines()
    assert len(lines) == len(c_methods(system)), proc.stdout
    assert all(" status 0 " in line for line in lines), proc.stdout


def _sanitized_run(name: str, tmp_path: Path) -> None:
    system = builtin(name)
    exe = build_driver(system, tmp_path / name, ["-O1", *SANITIZE])
    proc = subprocess.run(
        [str(exe), *_args(system)],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, **ENV},
    )
    _check_output(proc, "sanitizer", system)


def test_the_suites_cover_a_coupled_and_a_diagonal_system_with_terms() -> None:
    dp, fp = builtin("double_pendulum"), builtin("four_pendula")
    assert not dp.is_diagonal and fp.is_diagonal and fp.terms
    assert set(VALGRIND_SUITE) <= set(builtin_names())
    assert {n for n in builtin_names() if builtin(n).driven} == set(DRIVEN)
    assert {m.name for m in C_METHODS} >= {"vi", "vi4", "rattle", "rk45", "rk4"}


@pytest.mark.parametrize("name", [n for n in builtin_names() if n not in DRIVEN])
def test_sanitizers(name: str, tmp_path: Path) -> None:
    _sanitized_run(name, tmp_path)


def _one_short(src: str) -> str:
    """The driver with a workspace one double shorter than the header's WORK_SIZE."""
    short = src.replace(
        "exactly(DOUBLE_PENDULUM_WORK_SIZE)", "exactly(DOUBLE_PENDULUM_WORK_SIZE - 1)"
    )
    assert short != src
    return short


def test_a_sanitizer_report_fails_the_check(tmp_path: Path) -> None:
    """The check is live: a driver whose workspace is one double short is caught."""
    exe = build_driver(builtin("double_pendulum"), tmp_path, ["-O1", *SANITIZE], _one_short)
    proc = subprocess.run(
        [str(exe), "0.01", "0", "5"], capture_output=True, text=True, check=False,
        env={**os.environ, **ENV},
    )  # fmt: skip
    with pytest.raises(AssertionError, match="sanitizer report"):
        _check_output(proc, "sanitizer", builtin("double_pendulum"))


def _memcheck(exe: Path, args: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["valgrind", "--error-exitcode=1", "--leak-check=full", "--errors-for-leak-kinds=all",
         "-q", str(exe), *args],
        capture_output=True, text=True, check=False,
    )  # fmt: skip


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind not installed")
@pytest.mark.parametrize("name", VALGRIND_SUITE)
def test_valgrind_memcheck(name: str, tmp_path: Path) -> None:
    system = builtin(name)
    proc = _memcheck(build_driver(system, tmp_path, ["-O1"]), _args(system))
    assert "Invalid" not in proc.stderr and "definitely lost" not in proc.stderr, proc.stderr
    _check_output(proc, "valgrind", system)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind not installed")
def test_valgrind_report_fails_the_check(tmp_path: Path) -> None:
    exe = build_driver(builtin("double_pendulum"), tmp_path, ["-O1"], _one_short)
    proc = _memcheck(exe, ["0.01", "0", "5"])
    assert proc.returncode == 1 and "Invalid" in proc.stderr
