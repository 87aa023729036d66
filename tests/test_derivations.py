"""The disk cache of derivations (`s2gen.derivations`): what it reads back gives the same
emitted files byte for byte as a derivation from scratch, a damaged entry is never trusted,
and writers racing on one entry leave a whole one."""

from __future__ import annotations

import logging
import multiprocessing
import os
import pickle
import subprocess
import sys
from pathlib import Path

import pytest

from s2gen import derivations
from s2gen.derivations import cached, entry_path, uncached
from s2gen.emit import clear_caches, emit
from s2gen.systems import builtin

#: A fresh process that emits one system's C and NumPy files into a folder.
EMIT = r"""
import sys
from pathlib import Path
from s2gen.emit import emit
from s2gen.systems import builtin
out = Path(sys.argv[2])
for lang in ("c", "numpy"):
    for name, text in emit(builtin(sys.argv[1]), lang).items():
        (out / name).write_text(text)
"""


def _emit_in_process(name: str, cache: Path, out: Path, hashseed: str) -> dict[str, str]:
    out.mkdir(parents=True)
    env = {**os.environ, "S2GEN_CACHE": str(cache), "PYTHONHASHSEED": hashseed}
    subprocess.run([sys.executable, "-c", EMIT, name, str(out)], env=env, check=True)
    return {p.name: p.read_text() for p in sorted(out.iterdir())}


def _drop_emitted(cache: Path) -> None:
    """Remove the cached emitted files, so that the next emission reads only derivations."""
    for folder in (cache / "emitted").iterdir():
        for file in folder.iterdir():
            file.unlink()
        folder.rmdir()


@pytest.mark.parametrize("name", ["double_pendulum", "molecular", "rope"])
def test_derivations_read_back_emit_the_same_bytes(name: str, tmp_path: Path) -> None:
    """A process with an empty cache folder derives everything; a second one (another hash
    seed, the emitted files removed so that only the derivations and compiled templates are
    reused) emits the same files byte for byte, so does a third after every entry was
    truncated, and so does a derivation in this process with no cache at all. The coupled
    (dense), diagonal and banded solvers each read their own generic kernels."""
    cache = tmp_path / "cache"
    cold = _emit_in_process(name, cache, tmp_path / "cold", "1")
    entries = {p.parent.name for p in (cache / "derived").rglob("*.pickle")}
    assert entries == {"generic", "factor", "cse", "templates"}
    _drop_emitted(cache)
    assert _emit_in_process(name, cache, tmp_path / "warm", "2") == cold
    for path in (cache / "derived").rglob("*.pickle"):
        _damage(path, "truncated")
    _drop_emitted(cache)
    assert _emit_in_process(name, cache, tmp_path / "damaged", "3") == cold
    clear_caches()
    system = builtin(name)
    fresh = {**emit(system, "c", cache=False), **emit(system, "numpy", cache=False)}
    assert fresh == cold


def test_read_back_derivations_are_not_derived_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Once a system's derivations are on disk, emitting it again (with no emitted files and
    nothing kept in the process) derives no generic kernel, factors nothing and eliminates no
    subexpression, and gives the same files."""
    from s2gen.equations import assemble
    from s2gen.passes import cse, factor

    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path))
    clear_caches()
    first = emit(builtin("four_pendula"), "c", cache=True)
    clear_caches()

    def refuse(*args: object) -> None:
        raise AssertionError("derived again")

    for module, name in ((assemble, "_derive_generic"), (factor, "_factored_kernel")):
        monkeypatch.setattr(module, name, refuse)
    monkeypatch.setattr(cse, "_eliminate", refuse)
    _drop_emitted(tmp_path)
    assert emit(builtin("four_pendula"), "c", cache=True) == first
    clear_caches()


def test_uncached_emission_reads_and_writes_no_derivation(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`emit(..., cache=False)` derives from scratch: nothing is written under derived/."""
    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path))
    clear_caches()
    emit(builtin("double_pendulum"), "c", cache=False)
    clear_caches()
    assert not (tmp_path / "derived").exists()


def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) - 7])
    elif how == "flipped":
        path.write_bytes(data[:-1] + bytes([data[-1] ^ 1]))
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "header":
        path.write_bytes(data.replace(b"derivation 1", b"derivation 0", 1))
    else:  # a whole other pickle under the entry's name, without its checksum line
        path.write_bytes(pickle.dumps(("not", "this")))


@pytest.mark.parametrize("how", ["truncated", "flipped", "empty", "header", "foreign"])
def test_a_damaged_entry_is_derived_again(
    how: str, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A truncated, altered, emptied, mislabelled or replaced entry is reported and derived
    again, and the rewritten entry is read back without deriving."""
    calls: list[int] = []

    def derive() -> tuple[int, ...]:
        calls.append(1)
        return tuple(range(1000))

    assert cached(tmp_path, "t", "key", derive) == tuple(range(1000))
    _damage(entry_path(tmp_path, "t", "key"), how)
    with caplog.at_level(logging.WARNING, logger="s2gen.derivations"):
        assert cached(tmp_path, "t", "key", derive) == tuple(range(1000))
    assert len(calls) == 2
    assert "damaged" in caplog.text
    assert cached(tmp_path, "t", "key", derive) == tuple(range(1000))
    assert len(calls) == 2


def test_a_damaged_generic_entry_does_not_change_the_emitted_code(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every derivation entry of a system truncated: the next emission derives them again and
    writes the same files."""
    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path))
    clear_caches()
    first = emit(builtin("lj_cutoff"), "numpy", cache=False)
    emit(builtin("lj_cutoff"), "numpy", cache=True)
    clear_caches()
    for path in (tmp_path / "derived").rglob("*.pickle"):
        _damage(path, "truncated")
    _drop_emitted(tmp_path)
    assert emit(builtin("lj_cutoff"), "numpy", cache=True) == first
    clear_caches()


#: A value big enough that writing it takes many system calls.
_BIG = tuple(float(k) for k in range(200_000))


def _writer(path: str, rounds: int) -> None:
    for _ in range(rounds):
        derivations._write(Path(path), _BIG)


def test_concurrent_writers_leave_a_whole_entry(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Four processes rewrite one entry over and over while this one reads it: every read finds
    no entry or the whole value (never a damaged one), and no temporary file is left."""
    path = entry_path(tmp_path, "race", "big")
    context = multiprocessing.get_context("spawn")
    writers = [context.Process(target=_writer, args=(str(path), 40)) for _ in range(4)]
    for w in writers:
        w.start()
    seen = 0
    with caplog.at_level(logging.WARNING, logger="s2gen.derivations"):
        while any(w.is_alive() for w in writers):
            value = derivations._read(path)
            if value is not None:
                assert value == _BIG
                seen += 1
    assert "damaged" not in caplog.text, "a reader found a damaged entry while writers raced"
    for w in writers:
        w.join()
        assert w.exitcode == 0
    assert seen > 0
    assert derivations._read(path) == _BIG
    assert [p.name for p in path.parent.iterdir()] == [path.name]


def test_uncached_block_derives_every_time(tmp_path: Path) -> None:
    """Inside `uncached()` an existing entry is not read, and no new one is written."""
    cached(tmp_path, "t", "a", lambda: 1)
    with uncached():
        assert cached(tmp_path, "t", "a", lambda: 2) == 2
        assert cached(tmp_path, "t", "b", lambda: 3) == 3
    assert not entry_path(tmp_path, "t", "b").exists()
    assert cached(tmp_path, "t", "a", lambda: 4) == 1


def test_compiled_templates_are_read_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A second Environment takes the compiled template from disk (it compiles nothing) and
    renders the same text as the first; a truncated entry is compiled again."""
    import jinja2

    from s2gen.render import TemplateCache

    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path))

    def fresh() -> jinja2.Environment:
        loader = jinja2.DictLoader({"t.jinja": "{% for k in range(n) %}{{ k * k }} {% endfor %}"})
        return jinja2.Environment(loader=loader, bytecode_cache=TemplateCache())

    first = fresh().get_template("t.jinja").render(n=5)
    assert first == "0 1 4 9 16 "
    (entry,) = (tmp_path / "derived" / "templates").iterdir()
    second = fresh()

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("compiled again")

    monkeypatch.setattr(second, "compile", refuse)
    assert second.get_template("t.jinja").render(n=5) == first
    _damage(entry, "truncated")
    third = fresh()
    compiled: list[int] = []
    compile_ = third.compile

    def counting(*args: object, **kwargs: object) -> object:
        compiled.append(1)
        return compile_(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(third, "compile", counting)
    assert third.get_template("t.jinja").render(n=5) == first
    assert compiled == [1]


def test_structural_text_tells_apart_what_srepr_tells_apart() -> None:
    """The cache keys' text (`structural_text`) of two objects is the same exactly when
    SymPy's own full form (`sympy.srepr`) is: over symbols differing only in assumptions,
    Dummies, undefined functions, numbers of each type, containers, and the generic kernels'
    own expressions (equal trees built apart, and every pair of distinct outputs)."""
    import sympy as sp

    from s2gen.derivations import structural_text
    from s2gen.equations.continuous import continuous_kernels

    x, xr = sp.Symbol("x"), sp.Symbol("x", real=True)
    f, fr = sp.Function("f"), sp.Function("f", real=True)
    items: list[object] = [
        x, xr, sp.Dummy("x"), sp.Dummy("x"), f(x), fr(x), f(xr), sp.Integer(1) + x,
        sp.Float(1.0) + x, sp.Rational(1, 2) * x, sp.Float(0.5) * x, sp.sin(x), sp.sin(xr),
        sp.cos(x), sp.Max(x, xr), (x,), [x], (x, xr), (), sp.Tuple(x), sp.Tuple(),
        sp.ImmutableMatrix([[x, 1]]), sp.ImmutableMatrix([[x], [1]]), sp.Integer(2), 2, 2.0,
        "x", None, sp.Piecewise((x, xr > 0), (1, True)), sp.Derivative(f(x), x),
        sp.Subs(f(x), x, 1), sp.pi, sp.Float("0.1", 30), sp.Float("0.1", 15),
    ]  # fmt: skip
    exprs = [e for k in continuous_kernels(False) for o in k.outputs for e in o.exprs]
    items += exprs[:40] + [sp.sympify(sp.srepr(e)) for e in exprs[:5]]
    texts = [structural_text(a) for a in items]
    forms = [sp.srepr(a) for a in items]
    for i, (ti, fi) in enumerate(zip(texts, forms)):
        for tj, fj in zip(texts[i:], forms[i:]):
            assert (ti == tj) == (fi == fj), (fi, fj)
