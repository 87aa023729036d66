"""Shared fixtures: the systems the verification tests run on."""

from __future__ import annotations

from pathlib import Path

import pytest

from s2gen.system import System
from s2gen.systems import builtin, resolve

SPECS = Path(__file__).parent / "specs"


def three_bodies() -> System:
    """Three bodies on a sphere with the cotangent potential (diagonal M), from a TOML text."""
    from s2gen.spec import load_spec_text

    pairs = [(1, 2), (1, 3), (2, 3)]
    terms = " + ".join(f"dot(q{i}, q{j})/sqrt(1 - dot(q{i}, q{j})**2)" for i, j in pairs)
    text = f"""
name = "three"
bodies = 3
[parameters]
m = 1.0
gamma = 1.0
[inertia]
diagonal = ["m", "m", "m"]
[potential]
V = "-gamma*({terms})"
[initial]
q = [[0, -1, 0], [0, 0, 1], [-1, 0, 0]]
omega = [[0, 0, -1.1], [1, 0, 0], [0, 1, 0]]
[run]
h = 0.001
T = 10.0
"""
    return load_spec_text(text, origin="tests/conftest.py three_bodies")


SYSTEMS = {
    "double_pendulum": lambda: builtin("double_pendulum"),
    "three": three_bodies,
    "chain4": lambda: resolve(str(SPECS / "chain4.toml")),
    "springs4": lambda: resolve(str(SPECS / "springs4.toml")),
}


@pytest.fixture(scope="session", params=sorted(SYSTEMS))
def system(request: pytest.FixtureRequest) -> System:
    return SYSTEMS[request.param]()
