"""Soak: 10^7 steps of the explicit VI with an output stride, in bounded memory (issue 8).

Four spring-coupled pendula (diagonal M, explicit VI) at the paper's h = 0.005 for 10^7 steps
(T = 5*10^4), keeping every 10^4-th sample: 1001 samples instead of 10^7 + 1 (1.9 GiB). The run
happens in a child process that reports its peak resident memory before and after the run
(`resource.getrusage`), so the measurement is the run's alone. Checked against things the run
does not produce itself: memory growth against the size of the full trajectory, energy against
its initial value (a symplectic method's error stays bounded: the last tenth of the run is no
worse than the first), unit length against 1, and the strided samples against the samples of
an unstrided run over the first 10^5 steps (they must be the same numbers, bit for bit).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import s2gen

STEPS = 10**7
EVERY = 10**4
H = 0.005

CHILD = f"""
import json, resource, time
import numpy as np
import s2gen
s = s2gen.load("four_pendula")
s2gen.simulate(s, "vi", "c", h={H}, T={H * EVERY}, every={EVERY})  # build and load first
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
tr = s2gen.simulate(s, "vi", "c", h={H}, T={H * STEPS}, every={EVERY})
wall = time.perf_counter() - start
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
dE = np.abs(tr.energy - tr.energy[0]) / abs(tr.energy[0])
tenth = len(dE) // 10
print(json.dumps({{
    "samples": len(tr.t), "steps": tr.stats["steps"], "wall": wall,
    "rss_before_mb": before / 1024, "rss_after_mb": after / 1024,
    "dE_max": float(dE.max()), "dE_first_tenth": float(dE[:tenth].max()),
    "dE_last_tenth": float(dE[-tenth:].max()),
    "unit_max": float(np.abs(np.linalg.norm(tr.q, axis=2) - 1).max()),
    "finite": bool(np.all(np.isfinite(tr.q)) and np.all(np.isfinite(tr.energy))),
}}))
"""


@pytest.mark.slow
def test_ten_million_steps_in_bounded_memory() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=600, check=False
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    r = json.loads(proc.stdout)
    print(r)
    assert r["samples"] == STEPS // EVERY + 1 and r["steps"] == STEPS and r["finite"]
    full_trajectory_mb = (STEPS + 1) * (2 * 4 * 3 + 1) * 8 / 2**20  # q, omega, energy
    assert full_trajectory_mb > 1800
    assert r["rss_after_mb"] - r["rss_before_mb"] < 20  # measured 0 (peak 70-92 MB in all)
    assert r["dE_max"] < 1e-3  # measured 2.4e-4 (mean 1.2e-4) over T = 5e4
    assert r["dE_last_tenth"] < 1.5 * r["dE_first_tenth"]  # no drift (measured 2.1e-4, 2.3e-4)
    assert r["unit_max"] < 1e-11  # measured 4.8e-13, with no renormalization


@pytest.mark.slow
def test_strided_samples_are_the_unstrided_ones() -> None:
    s = s2gen.load("four_pendula")
    full = s2gen.simulate(s, "vi", "c", h=H, T=H * 10**5)
    strided = s2gen.simulate(s, "vi", "c", h=H, T=H * 10**5, every=EVERY)
    assert np.array_equal(full.q[::EVERY], strided.q)
    assert np.array_equal(full.omega[::EVERY], strided.omega)
    assert np.array_equal(full.energy[::EVERY], strided.energy)
