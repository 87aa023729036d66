"""Term tables that read files: a term's list of bodies or pairs (``pairs = { file =
"bonds.csv" }``) and its per-member data (``data = { k = { file = "k.txt" } }``), in
[[potential.body]], [[potential.pair]] and [[forces.pair]]. The same system written inline and
with files is the same module (the same spec digest) and runs the same trajectory bit for bit
(the inline one itself in C and NumPy); every bad file is a one-line SpecError naming
the term, its key and the file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from s2gen.runtime import simulate
from s2gen.spec import load_spec, load_spec_text
from s2gen.system import SpecError

N = 7
RNG = np.random.default_rng(35)
PAIRS = np.array([[1, 3], [2, 5], [6, 4], [3, 2], [7, 1], [5, 7], [4, 1]])
STIFF = 0.2 + RNG.random(len(PAIRS))
BODIES = np.array([2, 4, 7])
PULL = RNG.normal(scale=0.3, size=(len(BODIES), 3))
DAMP = 0.05 + 0.1 * RNG.random(len(PAIRS))
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.5, size=(N, 3)))


def _rows(a: np.ndarray) -> str:
    return repr(a.tolist())


def _spec(bodies: str, pull: str, pairs: str, stiff: str, damp_pairs: str, damp: str) -> str:
    """The test system with each list and datum as given (inline or a file table): springs
    over listed pairs with their own stiffness, a pull on listed bodies, and damping over
    listed pairs with its own coefficient."""
    return (
        f'name = "termfiles"\nbodies = {N}\n[parameters]\nm = 1.0\n'
        '[inertia]\ndiagonal = "m*(1 + i/10)"\n[potential]\n'
        f'[[potential.body]]\nV = "dot(f, q)"\nbodies = {bodies}\ndata = {{ f = {pull} }}\n'
        f'[[potential.pair]]\nV = "k*dot(qi - qj, qi - qj)/2"\npairs = {pairs}\n'
        f"data = {{ k = {stiff} }}\n"
        '[[forces.pair]]\nFi = "-b*cross(qi, wi - wj)"\nFj = "-b*cross(qj, wj - wi)"\n'
        f"pairs = {damp_pairs}\ndata = {{ b = {damp} }}\n"
        f"[initial]\nq = {_rows(Q0)}\nomega = {_rows(W0)}\n"
    )


INLINE = _spec(_rows(BODIES), _rows(PULL), _rows(PAIRS), _rows(STIFF), _rows(PAIRS), _rows(DAMP))


def _file(name: str) -> str:
    return f'{{ file = "{name}" }}'


def test_lists_and_term_data_from_files_run_as_inline(tmp_path: Path) -> None:
    inline = load_spec_text(INLINE)
    np.savetxt(tmp_path / "bodies.txt", BODIES, fmt="%d")
    np.save(tmp_path / "pull.npy", PULL)
    np.savetxt(tmp_path / "bonds.csv", PAIRS, fmt="%d", delimiter=",")
    np.savetxt(tmp_path / "k.txt", STIFF, fmt="%.17g")
    np.save(tmp_path / "bonds.npy", PAIRS)
    np.savetxt(tmp_path / "b.csv", DAMP, fmt="%.17g")
    names = ("bodies.txt", "pull.npy", "bonds.csv", "k.txt", "bonds.npy", "b.csv")
    (tmp_path / "s.toml").write_text(_spec(*(_file(n) for n in names)))
    filed = load_spec(tmp_path / "s.toml")
    assert filed.spec_digest() == inline.spec_digest()  # the same module
    truth = simulate(inline, "rk4", "c", h=0.01, T=0.3)
    other = simulate(inline, "rk4", "numpy", h=0.01, T=0.3)  # (no reference for forces)
    assert np.max(np.abs(truth.q - other.q)) < 1e-12  # the inline system runs alike
    run = simulate(filed, "rk4", "c", h=0.01, T=0.3)
    assert np.array_equal(run.q, truth.q) and np.array_equal(run.omega, truth.omega)


BAD = [
    ("missing", "pairs", {}, "no such file"),
    ("fractional", "pairs", {"bonds.csv": "1, 2.5\n2, 3\n"}, "row 1 is not whole body indices"),
    ("three columns", "pairs", {"bonds.csv": "1, 2, 3\n"}, "expected a pair i, j per line"),
    ("zero-based", "pairs", {"bonds.csv": "0, 1\n1, 2\n"}, "(indices are 1-based)"),
    ("same body", "pairs", {"bonds.csv": "2, 2\n"}, "joins body 2 with itself"),
    ("text", "pairs", {"bonds.csv": "a, b\n"}, "cannot read numbers from it"),
    ("short data", "k", {"k.txt": "1.0\n2.0\n"}, "expected 7 values (one per listed pair), got 2"),
    ("vector data", "k", {"k.txt": "1 2\n"}, "expected one number or 3 numbers per line (one"),
]


@pytest.mark.parametrize(("case", "key", "files", "fragment"), BAD, ids=[b[0] for b in BAD])
def test_bad_term_files_are_one_line_spec_errors(
    case: str, key: str, files: dict[str, str], fragment: str, tmp_path: Path
) -> None:
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    pairs = _file("bonds.csv") if key == "pairs" else _rows(PAIRS)
    stiff = _file("k.txt") if key == "k" else _rows(STIFF)
    text = _spec(_rows(BODIES), _rows(PULL), pairs, stiff, _rows(PAIRS), _rows(DAMP))
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(SpecError) as info:
        load_spec(tmp_path / "s.toml")
    message = str(info.value)
    assert "\n" not in message and fragment in message, message
    assert "[[potential.pair]] #1" in message, message
    if case not in ("same body", "zero-based", "short data"):  # those are the term's checks
        assert ("bonds.csv" if key == "pairs" else "k.txt") in message, message


def test_a_relative_term_file_in_spec_text_without_a_folder_says_what_to_do() -> None:
    text = _spec(_file("b.txt"), _rows(PULL), _rows(PAIRS), _rows(STIFF), _rows(PAIRS), _rows(DAMP))
    with pytest.raises(SpecError, match=r"\[\[potential.body\]\] #1 bodies: file 'b.txt' is rel"):
        load_spec_text(text)


def test_a_saved_trajectory_rebuilds_its_system_from_the_spec_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The spec text a trajectory records names its files relative to the spec's folder, which
    it records too: rebuilt from another working folder it reads the same files (the same
    digest); with a file gone, the one-line error names it."""
    from s2gen.runtime.trajectory import Trajectory

    specs = tmp_path / "specs"
    specs.mkdir()
    np.savetxt(specs / "bonds.csv", PAIRS, fmt="%d", delimiter=",")
    np.save(specs / "k.npy", STIFF)
    text = _spec(
        _rows(BODIES), _rows(PULL), _file("bonds.csv"), _file("k.npy"), _rows(PAIRS), _rows(DAMP)
    )
    (specs / "s.toml").write_text(text)
    system = load_spec(specs / "s.toml")
    saved = simulate(system, "rk4", "c", h=0.01, T=0.05).save(tmp_path / "run.npz")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    rebuilt = Trajectory.load(saved).rebuild()
    assert rebuilt.spec_digest() == system.spec_digest() == load_spec_text(INLINE).spec_digest()
    (specs / "k.npy").unlink()
    with pytest.raises(SpecError, match=r"data\.k: file '.*k\.npy': no such file"):
        Trajectory.load(saved).rebuild()
