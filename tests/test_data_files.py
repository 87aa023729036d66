"""Per-body data read from files ([data] c = { file = "c.npy" }, also .txt and .csv, and in
[inertia.data]): the same system with its data inline and in files runs the same trajectory
bit for bit from the same module; a million values load from .npy files well within the time
that TOML needs to parse them inline; every bad file is a one-line SpecError naming the key
and the file; the spec's digest follows the file's content, not its name."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from s2gen.runtime import simulate
from s2gen.spec import define_system, load_spec, load_spec_text
from s2gen.system import SpecError

N = 6
RNG = np.random.default_rng(34)
CHARGE = RNG.normal(size=N)
OFFSET = RNG.normal(scale=0.1, size=(N, 3))
LENGTH = 1 + RNG.random(N)
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.5, size=(N, 3)))


def _spec(c: str, o: str, length: str) -> str:
    """The test system's TOML with the three data entries as given (inline lists or files):
    charges and offsets read by an all-pairs term, lengths by the per-body inertia."""
    rows = ", ".join(f"[{', '.join(repr(float(x)) for x in row)}]" for row in Q0)
    spins = ", ".join(f"[{', '.join(repr(float(x)) for x in row)}]" for row in W0)
    return (
        f'name = "filed"\nbodies = {N}\n[parameters]\nk = 0.3\ng = 1.0\n'
        f'[inertia]\ndiagonal = "l**2"\n[inertia.data]\nl = {length}\n'
        '[potential]\n[[potential.body]]\nV = "-c*g*q[2] + dot(o, q)"\n'
        '[[potential.pair]]\nV = "k*ci*cj/norm(qi - qj + e1/10) + dot(qi, oi - oj)"\n'
        f'pairs = "all"\n[data]\nc = {c}\no = {o}\n'
        f"[initial]\nq = [{rows}]\nomega = [{spins}]\n"
    )


def _inline(values: np.ndarray) -> str:
    return repr(values.tolist())


def test_data_from_npy_and_txt_run_as_the_same_data_inline(tmp_path: Path) -> None:
    inline = load_spec_text(_spec(_inline(CHARGE), _inline(OFFSET), _inline(LENGTH)))
    np.save(tmp_path / "c.npy", CHARGE)
    np.save(tmp_path / "o.npy", OFFSET)
    np.savetxt(tmp_path / "c.txt", CHARGE, fmt="%.17g")
    np.savetxt(tmp_path / "o.csv", OFFSET, fmt="%.17g", delimiter=",")
    np.savetxt(tmp_path / "l.txt", LENGTH, fmt="%.17g")
    specs = {
        "npy": _spec('{ file = "c.npy" }', '{ file = "o.npy" }', '{ file = "l.txt" }'),
        "txt": _spec('{ file = "c.txt" }', '{ file = "o.csv" }', '{ file = "l.txt" }'),
    }
    truth = simulate(inline, "vi", "c", h=0.01, T=0.3, energy=False)
    reference = simulate(inline, "vi", "reference", h=0.01, T=0.3, energy=False)
    assert np.max(np.abs(truth.q - reference.q)) < 1e-12  # the inline system runs right
    for kind, text in specs.items():
        (tmp_path / f"{kind}.toml").write_text(text)
        filed = load_spec(tmp_path / f"{kind}.toml")
        assert filed.spec_digest() == inline.spec_digest(), kind  # the same module
        assert np.array_equal(filed.inertia_numeric(), inline.inertia_numeric()), kind
        run = simulate(filed, "vi", "c", h=0.01, T=0.3, energy=False)
        assert np.array_equal(run.q, truth.q), kind
        assert np.array_equal(run.omega, truth.omega), kind


@pytest.mark.timeout(20)
def test_a_million_values_load_from_npy_files(tmp_path: Path) -> None:
    """The existing inline test's data (1000 arrays of 1000 bodies) from .npy files, spec
    parse included. How fast is the benchmark's to say (benchmarks/data_load.py: about 0.1 s,
    against about 2 s inline); the limit here, as the inline test's, only catches a path
    that converts number by number (minutes for 10^6 values), on any machine."""
    n = 1000
    values = np.random.default_rng(1).normal(size=(n, 1000))
    for k in range(1000):
        np.save(tmp_path / f"d{k}.npy", values[:, k])
    entries = "".join(f'd{k} = {{ file = "d{k}.npy" }}\n' for k in range(1000))
    text = (
        f'name = "big"\nbodies = {n}\n[parameters]\nm = 1.0\n[inertia]\ndiagonal = "m"\n'
        '[potential]\n[[potential.body]]\nV = "d7*q[2] + d999*q[0]"\n[data]\n' + entries
    )
    (tmp_path / "big.toml").write_text(text)
    start = time.perf_counter()
    s = load_spec(tmp_path / "big.toml")
    print(f"loaded {values.size} data values from .npy in {time.perf_counter() - start:.3f} s")
    read = {d.name: d.values for d in s.terms[0].body_data}
    assert sorted(read) == ["d7", "d999"]
    assert read["d999"] == tuple(values[:, 999])


def test_the_digest_follows_the_file_content_not_its_name(tmp_path: Path) -> None:
    text = _spec('{ file = "c.npy" }', _inline(OFFSET), _inline(LENGTH))
    (tmp_path / "s.toml").write_text(text)
    np.save(tmp_path / "c.npy", CHARGE)
    before = load_spec(tmp_path / "s.toml")
    changed = CHARGE.copy()
    changed[3] = np.nextafter(changed[3], 10.0)  # one bit of one value
    np.save(tmp_path / "c.npy", changed)
    after = load_spec(tmp_path / "s.toml")
    assert after.spec_hash() != before.spec_hash()
    assert after.spec_digest() != before.spec_digest()
    np.save(tmp_path / "other.npy", CHARGE)  # the first content under another name
    renamed = load_spec_text(text.replace("c.npy", "other.npy"), folder=tmp_path)
    assert renamed.spec_digest() == before.spec_digest()
    # the inertia's per-body data as well
    np.save(tmp_path / "c.npy", CHARGE)
    np.savetxt(tmp_path / "l.txt", LENGTH)
    with_file = load_spec_text(text.replace(_inline(LENGTH), '{ file = "l.txt" }'), folder=tmp_path)
    np.savetxt(tmp_path / "l.txt", 2 * LENGTH)
    other = load_spec_text(text.replace(_inline(LENGTH), '{ file = "l.txt" }'), folder=tmp_path)
    assert with_file.spec_digest() == before.spec_digest() != other.spec_digest()


def _write(tmp_path: Path, name: str, content: object) -> None:
    """A bad file: an array for .npy (saved as given), text otherwise."""
    if isinstance(content, np.ndarray):
        np.save(tmp_path / name, content, allow_pickle=True)
    elif isinstance(content, bytes):
        (tmp_path / name).write_bytes(content)
    else:
        (tmp_path / name).write_text(str(content))


# (id, the entry in [data] c (or [inertia.data] l), files to write, fragments of the message)
BAD: list[tuple[str, str, dict[str, object], list[str]]] = [
    ("missing file", '{ file = "none.npy" }', {}, ["[data] c: file", "none.npy", "no such file"]),
    ("a folder", '{ file = "sub.npy" }', {"sub.npy/x.txt": "1"}, ["sub.npy", "cannot read"]),
    ("not an array", '{ file = "c.npy" }', {"c.npy": b"hello"}, ["c.npy", "cannot read numbers"]),
    (
        "pickled objects",
        '{ file = "c.npy" }',
        {"c.npy": np.array([{"a": 1}] * N, dtype=object)},
        ["c.npy", "holds Python objects"],
    ),
    ("too short", '{ file = "c.npy" }', {"c.npy": np.ones(N - 1)}, ["expected 6 rows", "got 5"]),
    ("wrong width", '{ file = "c.npy" }', {"c.npy": np.ones((N, 2))}, ["shape (n,) or (n, 3)"]),
    ("3-d", '{ file = "c.npy" }', {"c.npy": np.ones((N, 3, 1))}, ["got shape (6, 3, 1)"]),
    ("strings", '{ file = "c.npy" }', {"c.npy": np.array(["a"] * N)}, ["expected numbers"]),
    ("booleans", '{ file = "c.npy" }', {"c.npy": np.ones(N, bool)}, ["expected numbers"]),
    (
        "non-finite",
        '{ file = "c.npy" }',
        {"c.npy": np.array([1.0, 2.0, np.nan, 1.0, 1.0, 1.0])},
        ["c.npy", "row 3 is not finite"],
    ),
    ("text row lengths", '{ file = "c.txt" }', {"c.txt": "1 2\n3\n"}, ["c.txt", "cannot read"]),
    ("text words", '{ file = "c.csv" }', {"c.csv": "1\nx\n1\n1\n1\n1\n"}, ["cannot read"]),
    ("text 2 columns", '{ file = "c.txt" }', {"c.txt": "1 2\n" * N}, ["3 numbers per line"]),
    ("text inf", '{ file = "c.txt" }', {"c.txt": "1\n" * 5 + "inf\n"}, ["row 6 is not finite"]),
    ("unknown kind", '{ file = "c.json" }', {"c.json": "[1]"}, ["unknown kind '.json'"]),
    ("not a name", "{ file = 3 }", {}, ["[data] c: file: expected a file name"]),
    ("extra key", '{ file = "c.npy", rows = 2 }', {}, ["[data] c: unknown key 'rows'"]),
]


@pytest.mark.parametrize(("case", "entry", "files", "fragments"), BAD, ids=[b[0] for b in BAD])
def test_bad_data_files_are_one_line_spec_errors(
    tmp_path: Path, case: str, entry: str, files: dict[str, object], fragments: list[str]
) -> None:
    for name, content in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        _write(tmp_path, name, content)
    spec = tmp_path / "bad.toml"
    spec.write_text(_spec(entry, _inline(OFFSET), _inline(LENGTH)))
    with pytest.raises(SpecError) as info:
        load_spec(spec)
    _one_line(str(info.value), str(spec), fragments)


def test_bad_inertia_data_file_names_its_key(tmp_path: Path) -> None:
    np.save(tmp_path / "l.npy", np.ones(N + 1))
    spec = tmp_path / "bad.toml"
    spec.write_text(_spec(_inline(CHARGE), _inline(OFFSET), '{ file = "l.npy" }'))
    with pytest.raises(SpecError) as info:
        load_spec(spec)
    _one_line(str(info.value), str(spec), ["[inertia] data.l: file", "expected 6 rows"])


def test_a_relative_file_in_spec_text_without_a_folder_says_what_to_do(tmp_path: Path) -> None:
    text = _spec('{ file = "c.npy" }', _inline(OFFSET), _inline(LENGTH))
    with pytest.raises(SpecError) as info:
        load_spec_text(text, origin="<string>")
    _one_line(str(info.value), "<string>", ["[data] c", "has no folder", "folder=", "absolute"])
    np.save(tmp_path / "c.npy", CHARGE)  # an absolute name needs no folder
    absolute = str(tmp_path / "c.npy").replace("\\", "/")
    read = load_spec_text(text.replace('"c.npy"', f'"{absolute}"'))
    assert read.terms[0].body_data[0].values == tuple(CHARGE)


def test_a_file_table_in_python_says_to_pass_the_array() -> None:
    with pytest.raises(SpecError) as info:
        define_system(
            name="p",
            bodies=2,
            parameters={"m": 1.0},
            diagonal="m",
            potential="q1[2]",
            data={"c": {"file": "c.npy"}},
        )
    _one_line(str(info.value), "<python api>", ["[data] c", "numpy.load"])


def _one_line(message: str, origin: str, fragments: list[str]) -> None:
    """As the bad-input catalog asks: one line from the origin, with every fragment."""
    assert "\n" not in message and message == message.strip(), repr(message)
    assert len(message) < 300 + len(origin), message
    assert message.startswith(origin + ": "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
