"""A long derivation shows where it is: each stage is logged, and the command line prints the
stages on a terminal once the derivation has gone PROGRESS_DELAY seconds."""

from __future__ import annotations

import io
import logging
from pathlib import Path

import pytest

from s2gen import cli
from s2gen.emit import clear_caches
from s2gen.passes import PIPELINE, lower_system
from s2gen.systems import builtin


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_every_stage_is_logged_in_order(caplog: pytest.LogCaptureFixture) -> None:
    clear_caches()
    with caplog.at_level(logging.INFO, logger="s2gen.derive"):
        lower_system(builtin("four_pendula"))
    records = [r for r in caplog.records if r.name == "s2gen.derive"]
    expected = ["four_pendula: equations derived"]
    expected += [f"four_pendula: pass {name} done" for name, _ in PIPELINE]
    assert [r.getMessage() for r in records] == expected
    since = [r.since for r in records]  # type: ignore[attr-defined]
    assert since == sorted(since) and since[0] >= 0.0


@pytest.mark.parametrize("terminal", [True, False])
def test_the_command_line_shows_the_stages_on_a_terminal_only(
    terminal: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(cli, "PROGRESS_DELAY", 0.0)
    err = _Terminal() if terminal else io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    clear_caches()
    assert cli.main(["generate", "four_pendula", "--out", str(tmp_path / "out")]) == 0
    lines = err.getvalue().splitlines()
    if terminal:
        assert lines[0].startswith("deriving four_pendula: equations derived (")
        assert lines[-1].startswith("deriving four_pendula: pass workspace done (")
        assert len(lines) == 1 + len(PIPELINE)
    else:
        assert lines == []
    assert not logging.getLogger("s2gen.derive").handlers  # removed after the command
