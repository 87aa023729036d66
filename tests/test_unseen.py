"""The unseen-systems benchmark compares like with like: its hand-written C programs and the
emitted C, built as the benchmark builds them, end short runs of the same system in the same
state (two independent implementations of the same equations) with about the same number of
Newton iterations. No timings are checked here."""

from __future__ import annotations

import doctest
import importlib
import shutil

import numpy as np
import pytest
import unseen  # benchmarks/unseen.py (benchmarks/ is on pytest's pythonpath)
from unseen_systems import specs
from unseen_systems.cases import CASES, CaseMismatch, data_header
from unseen_systems.programs import build, run

from s2gen.spec import load_spec_text

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")

# short horizons, long enough for every body to move well away from its start
STEPS = {"yukawa": 150, "chain": 400}


@pytest.mark.parametrize("name", sorted(CASES))
def test_hand_written_and_emitted_agree(name, tmp_path):
    programs = build(CASES[name], tmp_path, ("O2",))
    hand = run(programs.hand["O2"], STEPS[name], 1)
    emitted = run(programs.emitted["O2"], STEPS[name], 1)
    assert hand.state.shape == emitted.state.shape == programs.initial.shape
    assert unseen.agreement(hand, emitted) < 1e-11
    # both moved: the agreement is not that of two programs that left the state alone
    assert np.max(np.abs(hand.state - programs.initial)) > 1e-2
    assert 0.0 < hand.energy_change < 1e-5 and 0.0 < emitted.energy_change < 1e-5
    if name == "chain":  # the same Newton start and stop rule; round-off decides a few steps
        assert hand.newton_per_step >= 2.0
        assert abs(hand.newton_per_step - emitted.newton_per_step) < 0.05
    else:
        assert hand.newton_per_step == emitted.newton_per_step == 0.0


def test_specs_are_written_by_their_script(tmp_path):
    """The shipped TOML files are what `specs.py` writes (its formulas document the numbers)."""
    for path in specs.write_specs(tmp_path):
        assert path.read_text() == (specs.HERE / path.name).read_text(), path.name


def test_data_header_refuses_a_spec_the_program_does_not_model():
    case = CASES["chain"]
    text = case.spec.read_text()
    assert "k*(1 - dot(qi, qj))" in text
    changed = load_spec_text(text.replace("k*(1 - dot(qi, qj))", "k*(1 - dot(qi, qj))**2"))
    with pytest.raises(CaseMismatch, match="potential.pair"):
        data_header(case, changed)
    heavier = load_spec_text(text.replace("m3 = 0.7", "m3 = 0.75"))
    assert "CH_MASS" in data_header(case, heavier)  # parameters may change: read, not retyped
    with pytest.raises(CaseMismatch, match="M is not"):
        data_header(case, load_spec_text(text.replace('"l10*l10*m10"', '"2*l10*l10*m10"')))


@pytest.mark.parametrize(
    "name",
    [
        "unseen",
        "unseen_systems",
        "unseen_systems.cases",
        "unseen_systems.programs",
        "unseen_systems.specs",
    ],
)
def test_benchmark_docstring_examples_run(name, tmp_path, monkeypatch):
    """The benchmark's modules live outside the package, so their examples run here."""
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0, name
