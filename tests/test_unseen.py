"""The unseen-systems benchmark compares like with like: its hand-written C programs and the
emitted C, built as the benchmark builds them, end short runs of the same system in the same
state (two independent implementations of the same equations) with about the same number of
Newton iterations. No timings are checked here."""

from __future__ import annotations

import doctest
import importlib
import shutil
import tomllib

import numpy as np
import pytest
import unseen  # benchmarks/unseen.py (benchmarks/ is on pytest's pythonpath)
from unseen_systems import specs
from unseen_systems.cases import CASES, CaseMismatch, data_header
from unseen_systems.programs import build, run

from s2gen.runtime import simulate
from s2gen.spec import load_spec_text

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")

# short horizons, long enough for every body to move well away from its start
STEPS = {"yukawa": 150, "chain": 400, "mixture": 80}
# |E_end - E_0| / |E_0| of those runs stays below this (the mixture's truncated forces jump
# at the cutoff, and its potential nearly cancels its kinetic energy)
ENERGY = {"yukawa": 1e-5, "chain": 1e-5, "mixture": 1e-3}


@pytest.mark.parametrize("name", sorted(CASES))
def test_hand_written_and_emitted_agree(name, tmp_path):
    programs = build(CASES[name], tmp_path, ("O2",))
    hand = run(programs.hand["O2"], STEPS[name], 1)
    emitted = run(programs.emitted["O2"], STEPS[name], 1)
    assert hand.state.shape == emitted.state.shape == programs.initial.shape
    assert unseen.agreement(hand, emitted) < 1e-11
    # both moved: the agreement is not that of two programs that left the state alone
    assert np.max(np.abs(hand.state - programs.initial)) > 1e-2
    assert 0.0 < hand.energy_change < ENERGY[name] and 0.0 < emitted.energy_change < ENERGY[name]
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


def _listed_pairs_form(text: str) -> str:
    """The yukawa spec with its numbers written per member instead of per body: the masses as
    the diagonal's numbers, the charges as the field term's data c, and the pair term over the
    listed pairs i < j (loop order) with ci, cj the charges of each pair's bodies."""
    spec = tomllib.loads(text)
    n, mass, charge = spec["bodies"], spec["data"]["m"], spec["data"]["c"]
    pairs = [(i, j) for i in range(1, n + 1) for j in range(i + 1, n + 1)]
    initial, run = spec["initial"], spec["run"]
    return "\n".join(
        [
            'name = "yukawa_listed"',
            f"bodies = {n}",
            "[parameters]",
            *(f"{k} = {v!r}" for k, v in spec["parameters"].items()),
            "[inertia]",
            f"diagonal = {mass!r}",
            "[[potential.body]]",
            'V = "-E*c*dot(e3, q)"',
            'bodies = "all"',
            "[potential.body.data]",
            f"c = {charge!r}",
            "[[potential.pair]]",
            'V = "A*ci*cj*exp(-kappa*norm(qi - qj))/norm(qi - qj)"',
            f"pairs = {[list(p) for p in pairs]!r}",
            "[potential.pair.data]",
            f"ci = {[charge[i - 1] for i, _ in pairs]!r}",
            f"cj = {[charge[j - 1] for _, j in pairs]!r}",
            "[initial]",
            f"q = {initial['q']!r}",
            f"omega = {initial['omega']!r}",
            "[run]",
            f"h = {run['h']!r}",
            f"T = {run['T']!r}",
            f'method = "{run["method"]}"',
            "",
        ]
    )


def test_yukawa_per_body_data_run_as_the_listed_pairs():
    """The shipped yukawa spec ([data] m, c; pairs = "all" reading ci, cj) and the same numbers
    written per member (4950 listed pairs with per-pair ci, cj) run the same trajectory in C."""
    text = CASES["yukawa"].spec.read_text()
    per_body, listed = load_spec_text(text), load_spec_text(_listed_pairs_form(text))
    assert [t.select for t in per_body.terms] == ["all", "all"]
    assert [t.count(listed.n) for t in listed.terms] == [100, 4950]
    assert np.array_equal(per_body.inertia_numeric(), listed.inertia_numeric())
    h = per_body.run.h
    new = simulate(per_body, "vi", "c", h=h, T=60 * h, energy=False)
    old = simulate(listed, "vi", "c", h=h, T=60 * h, energy=False)
    assert np.max(np.abs(new.q[-1] - per_body.q0)) > 1e-2  # the bodies moved
    assert np.max(np.abs(new.q - old.q)) < 1e-12
    assert np.max(np.abs(new.omega - old.omega)) < 1e-12


def test_yukawa_data_header_refuses_another_structure():
    case = CASES["yukawa"]
    text = case.spec.read_text()
    assert '\npairs = "all"\n' in text and "A*ci*cj*" in text
    assert "YK_CHARGE" in data_header(case, load_spec_text(text))
    with pytest.raises(CaseMismatch, match="pair term over 'all'"):
        data_header(case, load_spec_text(text.replace('\npairs = "all"\n', '\npairs = "chain"\n')))
    with pytest.raises(CaseMismatch, match="no cutoff"):
        data_header(
            case,
            load_spec_text(text.replace('\npairs = "all"\n', '\npairs = "all"\ncutoff = 1.5\n')),
        )
    with pytest.raises(CaseMismatch, match="potential.pair"):
        data_header(case, load_spec_text(text.replace("A*ci*cj*", "A*ci*ci*")))


def test_mixture_data_header_refuses_another_structure():
    case = CASES["mixture"]
    text = case.spec.read_text()
    assert '\ncutoff = "rc"\n' in text and "4*sqrt(ei*ej)*" in text
    assert "MX_SIGMA" in data_header(case, load_spec_text(text))
    with pytest.raises(CaseMismatch, match="potential.pair"):
        data_header(case, load_spec_text(text.replace("4*sqrt(ei*ej)*", "2*(ei + ej)*")))
    with pytest.raises(CaseMismatch, match="cutoff = rc"):
        data_header(case, load_spec_text(text.replace('\ncutoff = "rc"\n', "\ncutoff = 0.15\n")))
    with pytest.raises(CaseMismatch, match="cutoff = rc"):
        data_header(case, load_spec_text(text.replace('\ncutoff = "rc"\n', "\n")))


def test_small_mixture_agrees_between_c_numpy_and_reference():
    """96 particles of the mixture's two species (sizes and the cutoff scaled to their
    spacing): the emitted C (cell lists), NumPy (k-d tree) and the reference (a distance test
    per pair) run the same trajectory; the cutoff keeps some pairs and drops most."""
    system = load_spec_text(specs.mixture_spec(n=96))
    pair = system.terms[0]
    assert pair.cutoff is not None and pair.cutoff < 1.0  # a grid of 2 cells per axis
    q0, i, j = system.q0, *np.triu_indices(system.n, 1)
    near = int(np.sum(np.sum((q0[i] - q0[j]) ** 2, axis=1) < pair.cutoff**2))
    assert system.n < near < len(i) // 4
    h = system.run.h
    truth = simulate(system, "vi", "reference", h=h, T=100 * h, energy=False)
    assert np.max(np.abs(truth.q[-1] - q0)) > 1e-2  # the bodies moved
    for backend in ("c", "numpy"):
        run = simulate(system, "vi", backend, h=h, T=100 * h, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-11, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-10, backend


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
