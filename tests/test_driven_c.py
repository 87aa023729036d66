"""The emitted C of driven systems as a C program uses it: strict C99 and C++ compilation, and a
driver under AddressSanitizer and UndefinedBehaviorSanitizer with every caller array allocated
at exactly the size the header states (inputs nsteps * NINPUTS, trajectory, energy and work
nsteps + 1, workspace WORK_SIZE). Each driven method runs through integrate() with an input
array, again step by step through step() (which must end in integrate()'s final state bit for
bit, RK45 aside: its step() estimates its first adaptive step afresh), and once with a state
feedback written in C. Any sanitizer report, warning, failed
status, non-finite result or difference fails the test.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import s2gen
from s2gen import generate
from s2gen.methods import driven_methods
from s2gen.methods import method as method_record
from s2gen.system import System

SPECS = Path(__file__).parent / "specs"
#: The driven built-ins and test systems: every driven module kind (dense with velocity
#: forces, diagonal with forces and inputs, diagonal with time only, structured with time)
SYSTEMS = (
    "forced_double_pendulum",
    "kapitza",
    str(SPECS / "driven_double.toml"),
    str(SPECS / "driven_ring.toml"),
    "rope:n=4,top_radius=0.2",
)
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
STRICT = ["-Wall", "-Wextra", "-Werror"]
ENV = {
    "ASAN_OPTIONS": "halt_on_error=1:detect_leaks=1:abort_on_error=0",
    "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1",
}
REPORTS = ("AddressSanitizer", "LeakSanitizer", "runtime error:", "UndefinedBehaviorSanitizer")

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")


def _doubles(values: object) -> str:
    import numpy as np

    return ", ".join(repr(float(v)) for v in np.asarray(values, dtype=float).ravel())


def driver_source(system: System) -> str:
    """A C program: for each (method code, steps) on its command line, integrate() from t0 =
    0.25 with inputs that change every step, then step() over the same steps, then
    integrate() with a state feedback."""
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
    double *a = malloc((count > 0 ? count : 1) * sizeof *a);
    if (!a) {{ fprintf(stderr, "out of memory\\n"); exit(3); }}
    return a;
}}

/* state feedback: inputs from the time and the first body's state */
static void law(void *ctx, double t, const double *q, const double *w, double *u)
{{
    int k;
    (void)ctx;
    for (k = 0; k < {up}_NINPUTS; ++k) {{
        u[k] = 0.2 * sin(t + k) - 0.1 * q[k % 3] + 0.05 * w[(k + 1) % 3];
    }}
}}

int main(int argc, char **argv)
{{
    double h = atof(argv[1]);
    int i, bad = 0;
    double *p = exactly({up}_NPARAMS);
    {name}_options opt;
    {name}_default_params(p);
    {name}_default_options(&opt);
    for (i = 2; i + 1 < argc; i += 2) {{
        int method = atoi(argv[i]);
        long nsteps = atol(argv[i + 1]), k;
        size_t samples = (size_t)nsteps + 1;
        double *q = exactly(samples * {up}_NSTATE), *w = exactly(samples * {up}_NSTATE);
        double *en = exactly(samples), *W = exactly(samples), *work = exactly({up}_WORK_SIZE);
        double *u = exactly((size_t)nsteps * {up}_NINPUTS);
        double *qa = exactly({up}_NSTATE), *wa = exactly({up}_NSTATE);
        double *qb = exactly({up}_NSTATE), *wb = exactly({up}_NSTATE), *t, done;
        {name}_stats st;
        int status, stepped = {up}_OK, fed;
        for (k = 0; k < nsteps * {up}_NINPUTS; ++k) {{
            u[k] = 0.3 * cos(0.7 * (double)k);
        }}
        status = {name}_integrate(p, &opt, method, 0.25, h, nsteps, u, NULL, NULL, q_init, w_init,
                                  q, w, en, W, work, &st);
        for (k = 0; status == {up}_OK && k < (long)(samples * {up}_NSTATE); ++k)
            if (!isfinite(q[k]) || !isfinite(w[k])) {{ bad = 1; break; }}
        for (k = 0; status == {up}_OK && k < (long)samples; ++k)
            if (!isfinite(en[k]) || !isfinite(W[k])) {{ bad = 1; break; }}
        memcpy(qa, q_init, sizeof q_init);
        memcpy(wa, w_init, sizeof w_init);
        for (k = 0; stepped == {up}_OK && k < nsteps; ++k) {{
            stepped = {name}_step(p, &opt, method, 0.25 + (double)k * h, h, u + k * {up}_NINPUTS,
                                  qa, wa, qb, wb, &done, work, NULL);
            t = qa; qa = qb; qb = t; t = wa; wa = wb; wb = t;
        }}
        /* the adaptive methods' step() estimates its first step afresh (integrate() carries it) */
        bad |= stepped != {up}_OK || (method != {up}_METHOD_RK45 && method != {up}_METHOD_DOP853
            && (memcmp(qa, q + nsteps * {up}_NSTATE, sizeof q_init) != 0
                || memcmp(wa, w + nsteps * {up}_NSTATE, sizeof w_init) != 0));
        fed = {name}_integrate(p, &opt, method, 0.0, h, nsteps, NULL, law, NULL, q_init, w_init,
                               q, w, NULL, NULL, work, NULL);
        printf("method %d status %d steps %ld step %d feedback %d work %.17g\\n", method, status,
               st.steps, stepped, fed, W[status == {up}_OK ? nsteps : 0]);
        bad |= status != {up}_OK || fed != {up}_OK;
        free(q); free(w); free(en); free(W); free(work); free(u);
        free(qa); free(wa); free(qb); free(wb);
    }}
    free(p);
    return bad;
}}
"""


def _emitted(system: System, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for fname, text in generate(system, "c").items():
        (folder / fname).write_text(text)
    return folder / f"{system.name}.c"


@pytest.mark.parametrize("spec", SYSTEMS)
def test_strict_c99_and_cplusplus(spec: str, tmp_path: Path) -> None:
    source = _emitted(s2gen.load(spec), tmp_path)
    for cmd in (
        ["gcc", "-std=c99", "-Wpedantic", *STRICT, "-O2", "-c", str(source)],
        ["g++", "-x", "c++", *STRICT, "-O2", "-c", str(source)],
    ):
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr[-3000:]


@pytest.mark.parametrize("spec", SYSTEMS)
def test_sanitizers_on_driven_systems(spec: str, tmp_path: Path) -> None:
    system = s2gen.load(spec)
    source = _emitted(system, tmp_path)
    (tmp_path / "driver.c").write_text(driver_source(system))
    exe = tmp_path / "driver"
    cmd = ["gcc", "-std=c99", "-g", "-O1", *STRICT, *SANITIZE, "-o", str(exe),
           str(tmp_path / "driver.c"), str(source), f"-I{tmp_path}", "-lm"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    h = system.run.h or 0.01
    methods = driven_methods(rattle=not system.forces or system.is_diagonal)  # RK45 too
    runs = [(method_record(m).code, 40) for m in methods]
    args = [repr(h), *(str(x) for run in runs for x in run)]
    proc = subprocess.run(
        [str(exe), *args], capture_output=True, text=True, check=False, env={**os.environ, **ENV}
    )
    report = [line for line in proc.stderr.splitlines() if any(r in line for r in REPORTS)]
    assert not report, proc.stderr[-4000:]
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr[-3000:]}"
    lines = proc.stdout.splitlines()
    assert len(lines) == len(runs)
    assert all(" status 0 " in ln and " step 0 " in ln and " feedback 0 " in ln for ln in lines)


def test_the_control_example_keeps_the_pendulum_upright(tmp_path: Path) -> None:
    """examples/control, built and run as its README says: the LQR state feedback through
    step() brings the pendulum from 0.2 rad to within 1e-6 rad of the top in 10 s (the
    program's exit status), |q| = 1 to 1e-12 throughout; at the closed loop's slowest decay,
    |lambda| = 0.9823 per 5 ms step (3.57 /s), 0.2 rad fall to about 1e-16 rad
    (tests/test_control_lqr.py checks the closed loop itself)."""
    import sys

    example = Path(__file__).resolve().parent.parent / "examples" / "control"
    proc = subprocess.run(
        [
            "make",
            "-C",
            str(example),
            "run",
            f"BUILD={tmp_path}",
            f"S2GEN={sys.executable} -m s2gen",
            f"PYTHON={sys.executable}",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    last = next(line for line in proc.stdout.splitlines() if line.startswith("after "))
    tilt = float(last.split("tilt ")[1].split(" rad")[0])
    assert tilt < 1e-12, last
    assert float(last.split("= ")[1]) < 1e-12, last
